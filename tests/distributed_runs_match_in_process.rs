//! `--workers 1`, `--workers 3`, `--in-process` and the serial trainer give bitwise-identical
//! designs, policies, J and histories for the same seed: episodes come from per-(seed, k, e)
//! streams and the learner orders them before updating. The same holds with a policy lag
//! (`--lag 1`), where the learner updates on batch k while the workers sample batch k + 1.

mod support;

use std::path::Path;
use std::time::Duration;

use support::launch::{comparable, run, small_run, tiny_instance_file, with};

/// Runs `small_run` in every mode with `--lag lag`, asserts the results are equal, and returns
/// the serial trainer's.
fn every_mode_agrees(dir: &Path, lag: usize) -> serde_json::Value {
    let inst = tiny_instance_file(dir);
    let base = with(small_run(&inst, 11, 60), &["--lag", &lag.to_string()]);
    let mut results = Vec::new();
    for (name, extra) in
        [("w1", vec!["--workers", "1"]), ("w3", vec!["--workers", "3"]), ("ip", vec!["--in-process", "--workers", "2"])]
    {
        let out = dir.join(format!("{name}-lag{lag}.json"));
        let mut args = with(base.clone(), &extra);
        args.extend(["--out".to_string(), out.display().to_string()]);
        let o = run(&args, Duration::from_secs(120));
        assert!(o.status.success(), "{name}, lag {lag}: {}", String::from_utf8_lossy(&o.stderr));
        results.push((name, comparable(&out)));
    }
    // The library's serial trainer, for reference.
    let registry = support::registry();
    let env = registry.load(&inst, &[("kappa".into(), 0.9)]).unwrap();
    // The settings `small_run` passes on the command line.
    let config = envpg_ac::AcConfig { warmup: 20, eval_every: 20, lag, ..support::small_config(60) };
    let spec = envpg_ac::trainer::RunSpec::new(&env, 11, config);
    let serial = envpg_ac::trainer::train(&spec, &registry, |_| true).unwrap();
    let serial_path = dir.join(format!("serial-lag{lag}.json"));
    serial.save(&serial_path).unwrap();
    results.push(("serial", comparable(&serial_path)));
    let (first, reference) = &results[0];
    for (name, r) in &results[1..] {
        assert_eq!(r["zeta"], reference["zeta"], "lag {lag}, {name} vs {first}: zeta");
        assert_eq!(r["policy"], reference["policy"], "lag {lag}, {name} vs {first}: policy");
        assert_eq!(r["J"], reference["J"], "lag {lag}, {name} vs {first}: J");
        assert_eq!(r["history"], reference["history"], "lag {lag}, {name} vs {first}: history");
        assert_eq!(r, reference, "lag {lag}, {name} vs {first}");
    }
    results.pop().unwrap().1
}

#[test]
fn every_execution_mode_gives_the_same_run() {
    let dir = tempfile::tempdir().unwrap();
    every_mode_agrees(dir.path(), 0);
}

#[test]
fn a_lagged_run_is_the_same_in_every_mode_and_differs_from_an_unlagged_one() {
    let dir = tempfile::tempdir().unwrap();
    let lagged = every_mode_agrees(dir.path(), 1);
    assert_eq!(lagged["config"]["lag"], 1);
    // Batch k is sampled with θ_{k−1}: the iterates differ from the synchronous run's.
    let registry = support::registry();
    let env = registry.load(&tiny_instance_file(dir.path()), &[("kappa".into(), 0.9)]).unwrap();
    let config = envpg_ac::AcConfig { warmup: 20, eval_every: 20, ..support::small_config(60) };
    let spec = envpg_ac::trainer::RunSpec::new(&env, 11, config);
    let unlagged = serde_json::to_value(envpg_ac::trainer::train(&spec, &registry, |_| true).unwrap()).unwrap();
    assert_ne!(lagged["history"], unlagged["history"], "--lag 1 changed nothing");
}

#[test]
fn a_per_element_one_hot_run_is_the_same_distributed_and_serial_and_differs_from_per_state() {
    let dir = tempfile::tempdir().unwrap();
    let inst = tiny_instance_file(dir.path());
    let out = dir.path().join("per-element.json");
    let mut args = with(small_run(&inst, 11, 60), &["--state-onehot", "per-element", "--workers", "2"]);
    args.extend(["--out".to_string(), out.display().to_string()]);
    let o = run(&args, Duration::from_secs(120));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let distributed = comparable(&out);
    assert_eq!(distributed["config"]["state_onehot"], "per-element");
    // The workers build the learner's inputs: the serial trainer's run is the same.
    let registry = support::registry();
    let env = registry.load(&inst, &[("kappa".into(), 0.9)]).unwrap();
    let per_state = envpg_ac::AcConfig { warmup: 20, eval_every: 20, ..support::small_config(60) };
    let per_element = envpg_ac::AcConfig { state_onehot: envpg_ac::StateOnehot::PerElement, ..per_state.clone() };
    let serial = |config| {
        let path = dir.path().join("serial.json");
        let spec = envpg_ac::trainer::RunSpec::new(&env, 11, config);
        envpg_ac::trainer::train(&spec, &registry, |_| true).unwrap().save(&path).unwrap();
        comparable(&path)
    };
    assert_eq!(serial(per_element), distributed);
    assert_ne!(serial(per_state)["history"], distributed["history"], "per-element changed nothing");
}
