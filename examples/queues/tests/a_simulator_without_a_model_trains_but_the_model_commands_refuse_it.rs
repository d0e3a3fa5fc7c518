//! `queues-sim` is the queues as a black box: Algorithm 1 trains on it through the crate's
//! launcher (its result has no exact J, and says why), while the oracle and exact evaluation
//! refuse it with a clear error and exit code 2, writing nothing.

use std::process::Command;

fn run(bin: &str, args: &[&str]) -> std::process::Output {
    Command::new(bin)
        .args(args)
        // Default run directories (runs/<id>) stay out of the source tree.
        .env("ENVPG_RUNS_DIR", std::env::temp_dir().join("envpg-test-runs"))
        .output()
        .expect("the example's binaries run")
}

#[test]
fn queues_sim_trains_without_a_model_and_the_oracle_refuses_it() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sim.json");
    let o = run(
        env!("CARGO_BIN_EXE_queues-launch"),
        &["--instance", "queues-sim", "--preset", "smoke", "--workers", "2", "--quiet", "--out", out.to_str().unwrap()],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let r: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!(r["env"], "queues-sim");
    assert!(r["J"].is_null(), "{}", r["J"]);
    assert!(r["j_error"].as_str().unwrap().contains("has no model"), "{}", r["j_error"]);
    let zeta: Vec<f64> = serde_json::from_value(r["zeta"].clone()).unwrap();
    assert!(zeta.iter().all(|z| (0.05..=0.95).contains(z)), "ζ stays inside its bounds: {zeta:?}");

    let never = dir.path().join("never.json");
    for args in [
        vec!["oracle", "--instance", "queues-sim", "--out", never.to_str().unwrap()],
        vec!["evaluate", out.to_str().unwrap()],
        vec!["evaluate", "--instance", "queues-sim", "--zeta", "0.5,0.5"],
    ] {
        let o = run(env!("CARGO_BIN_EXE_queues-tools"), &args);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(
            stderr.contains("`queues-sim` has no model: the oracle and exact evaluation need one"),
            "{args:?}: {stderr}"
        );
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
    }
    assert!(!never.exists(), "the refused oracle wrote its output");
}
