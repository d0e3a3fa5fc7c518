//! The `envpg` binary end to end: instance generation, an oracle run whose result file
//! re-scores to the same J, and clear errors with exit code 2 on bad input.

use std::path::Path;
use std::process::{Command, Output};

fn envpg(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_envpg")).args(args).output().expect("envpg runs")
}

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn generate(dir: &Path, users: usize, uavs: usize) -> String {
    let path = dir.join("tiny.json");
    let o = envpg(&[
        "instance",
        "generate",
        "--users",
        &users.to_string(),
        "--uavs",
        &uavs.to_string(),
        "--clusters",
        "3",
        "--seed",
        "4",
        "--out",
        path.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    path.to_str().unwrap().to_owned()
}

#[test]
fn oracle_result_rescored_by_evaluate_matches() {
    let dir = tempfile::tempdir().unwrap();
    let inst = generate(dir.path(), 30, 3);
    let out = dir.path().join("r.json");
    let o =
        envpg(&["oracle", "--instance", &inst, "--kappa", "0.9", "--restarts", "2", "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("best J ="), "{}", stdout(&o));
    let r: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!(r["schema"], "envpg.result.v2");
    assert_eq!((r["env"].as_str(), r["instance"]["params"]["kappa"].as_f64()), (Some("uav"), Some(0.9)));
    assert_eq!(r["method"], "oracle");
    assert_eq!(r["zeta"].as_array().unwrap().len(), 6);
    assert_eq!(r["policy"].as_array().unwrap().len(), 33);
    let e = envpg(&["evaluate", out.to_str().unwrap()]);
    assert!(e.status.success(), "{}{}", stdout(&e), stderr(&e));
    assert!(stdout(&e).contains(" ok"), "{}", stdout(&e));
}

#[test]
fn evaluate_detects_a_tampered_j() {
    let dir = tempfile::tempdir().unwrap();
    let inst = generate(dir.path(), 20, 2);
    let out = dir.path().join("r.json");
    let o = envpg(&["oracle", "--instance", &inst, "--restarts", "1", "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let mut r: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    r["J"] = serde_json::json!(r["J"].as_f64().unwrap() * 0.99);
    std::fs::write(&out, serde_json::to_string(&r).unwrap()).unwrap();
    let e = envpg(&["evaluate", out.to_str().unwrap()]);
    assert_eq!(e.status.code(), Some(1));
    assert!(stdout(&e).contains("MISMATCH"), "{}", stdout(&e));
}

#[test]
fn bad_input_is_refused_with_exit_code_2() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.json");
    std::fs::write(&bad, r#"{"name":"x","n_uav":2,"users":[[0,0]],"dest":[1,1],"dest":[2,2]}"#).unwrap();
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["oracle", "--kappa", "1.5"], "kappa must be in (0, 1]"),
        (vec!["oracle", "--kappa", "NaN"], "kappa"),
        (vec!["oracle", "--instance", bad.to_str().unwrap()], "duplicate field `dest`"),
        (vec!["oracle", "--init", "1,2"], "ζ has 2 entries"),
        (vec!["oracle", "--cooling", "1.2"], "cooling"),
        (vec!["oracle", "--no-such-option"], "unexpected argument"),
        (vec!["evaluate", "/nonexistent/r.json"], "cannot read result file"),
    ];
    for (args, needle) in cases {
        let o = envpg(&args);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(needle), "{args:?}: {}", stderr(&o));
    }
}

#[test]
fn instance_check_summarises_the_bundled_instance() {
    let o = envpg(&["instance", "check", "uav271"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("environment `uav`") && stdout(&o).contains("277 states"), "{}", stdout(&o));
    for (name, env) in [("aac1800", "aac"), ("flpo-n10m4", "flpo")] {
        let o = envpg(&["instance", "check", name]);
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(stdout(&o).contains(&format!("environment `{env}`")), "{}", stdout(&o));
    }
}
