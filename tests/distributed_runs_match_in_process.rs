//! `--workers 1`, `--workers 3`, `--in-process` and the serial trainer give bitwise-identical
//! designs, policies, J and histories for the same seed: episodes come from per-(seed, k, e)
//! streams and the learner orders them before updating.

mod support;

use std::time::Duration;

use support::launch::{comparable, run, small_run, tiny_instance_file, with};

#[test]
fn every_execution_mode_gives_the_same_run() {
    let dir = tempfile::tempdir().unwrap();
    let inst = tiny_instance_file(dir.path());
    let base = small_run(&inst, 11, 60);
    let mut results = Vec::new();
    for (name, extra) in
        [("w1", vec!["--workers", "1"]), ("w3", vec!["--workers", "3"]), ("ip", vec!["--in-process", "--workers", "2"])]
    {
        let out = dir.path().join(format!("{name}.json"));
        let mut args = with(base.clone(), &extra);
        args.extend(["--out".to_string(), out.display().to_string()]);
        let o = run(&args, Duration::from_secs(120));
        assert!(o.status.success(), "{name}: {}", String::from_utf8_lossy(&o.stderr));
        results.push((name, comparable(&out)));
    }
    // The library's serial trainer, for reference.
    let registry = support::registry();
    let env = registry.load(&inst, &[("kappa".into(), 0.9)]).unwrap();
    // The settings `small_run` passes on the command line.
    let config = envpg_ac::AcConfig { warmup: 20, eval_every: 20, ..support::small_config(60) };
    let spec = envpg_ac::trainer::RunSpec::new(&env, 11, config);
    let serial = envpg_ac::trainer::train(&spec, &registry, |_| true).unwrap();
    let serial_path = dir.path().join("serial.json");
    serial.save(&serial_path).unwrap();
    results.push(("serial", comparable(&serial_path)));
    let (first, reference) = &results[0];
    for (name, r) in &results[1..] {
        assert_eq!(r["zeta"], reference["zeta"], "{name} vs {first}: zeta");
        assert_eq!(r["policy"], reference["policy"], "{name} vs {first}: policy");
        assert_eq!(r["J"], reference["J"], "{name} vs {first}: J");
        assert_eq!(r["history"], reference["history"], "{name} vs {first}: history");
        assert_eq!(r, reference, "{name} vs {first}");
    }
}
