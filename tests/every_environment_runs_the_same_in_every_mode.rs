//! The published problems run distributed with the UAV network's guarantees: for `flpo` and
//! `aac`, `--workers 2`, `--in-process` and the library's serial trainer give bitwise the same
//! result, and a worker killed with SIGKILL mid-run changes nothing.

mod support;

use std::time::Duration;

use envpg_ac::AcConfig;
use envpg_ac::trainer::{RunSpec, train};
use support::launch::{comparable, run, run_killing_worker_zero, with};

/// A short smoke-preset run of `instance` (flpo at κ = 0.9, so hops can miss).
fn short_run(instance: &str, iterations: usize) -> Vec<String> {
    let mut args = vec!["--instance", instance, "--preset", "smoke", "--seed", "3", "--quiet"];
    if instance.starts_with("flpo") {
        args.extend(["--kappa", "0.9"]);
    }
    let n = iterations.to_string();
    with(args.iter().map(|s| s.to_string()).collect(), &["--iterations", &n])
}

#[test]
fn flpo_and_aac_give_the_same_result_distributed_in_process_and_serial() {
    let dir = tempfile::tempdir().unwrap();
    let registry = support::registry();
    for instance in ["flpo-n10m4", "aac1800"] {
        let mut results = Vec::new();
        for (mode, extra) in [("w2", vec!["--workers", "2"]), ("ip", vec!["--in-process", "--workers", "2"])] {
            let out = dir.path().join(format!("{instance}-{mode}.json"));
            let args = with(short_run(instance, 12), &extra);
            let o = run(&with(args, &["--out", &out.display().to_string()]), Duration::from_secs(180));
            assert!(o.status.success(), "{instance} {mode}: {}", String::from_utf8_lossy(&o.stderr));
            results.push((mode, comparable(&out)));
        }
        let overrides: Vec<(String, f64)> =
            if instance.starts_with("flpo") { vec![("kappa".into(), 0.9)] } else { vec![] };
        let env = registry.load(instance, &overrides).unwrap();
        let config = AcConfig { iterations: 12, ..AcConfig::bundled("smoke").unwrap() };
        let serial = train(&RunSpec::new(&env, 3, config), &registry, |_| true).unwrap();
        let path = dir.path().join(format!("{instance}-serial.json"));
        serial.save(&path).unwrap();
        results.push(("serial", comparable(&path)));
        let (first, reference) = &results[0];
        assert_eq!(reference["env"], instance.split('-').next().unwrap().trim_end_matches("1800"));
        for (mode, r) in &results[1..] {
            assert_eq!(r["zeta"], reference["zeta"], "{instance}: {mode} vs {first}: zeta");
            assert_eq!(r["policy"], reference["policy"], "{instance}: {mode} vs {first}: policy");
            assert_eq!(r, reference, "{instance}: {mode} vs {first}");
        }
    }
}

#[test]
fn a_sigkilled_flpo_worker_changes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let iterations = 400;
    let base = short_run("flpo-n10m4", iterations);
    let reference = dir.path().join("reference.json");
    let o = run(
        &with(base.clone(), &["--in-process", "--out", &reference.display().to_string()]),
        Duration::from_secs(180),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));

    let run_dir = dir.path().join("run");
    let out = dir.path().join("killed.json");
    let (rd, o_s) = (run_dir.display().to_string(), out.display().to_string());
    let args = with(
        base,
        &["--workers", "2", "--emulator-cost-us", "600", "--worker-timeout-ms", "400", "--run-dir", &rd, "--out", &o_s],
    );
    let o = run_killing_worker_zero(&args, &run_dir, 1000, Duration::from_secs(240));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    assert!(stderr.contains("worker 0 exited (signal 9); starting a replacement"), "{stderr}");
    assert_eq!(comparable(&out), comparable(&reference), "the disturbed run must equal the undisturbed one");
    let r: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    let per_iteration = AcConfig::bundled("smoke").unwrap();
    let episodes = iterations * (per_iteration.episodes + per_iteration.explore_episodes);
    assert_eq!(r["details"]["link"]["episodes"], episodes, "{}", r["details"]["link"]);
}
