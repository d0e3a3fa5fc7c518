//! The learner killed with SIGKILL: `envpg-launch --resume DIR` continues from the last
//! checkpoint (θ, φ, φ⁻, ζ, optimiser moments, α, k, visit counts, history) and ends bitwise
//! identical to an uninterrupted run — also with a policy lag, whose checkpoint carries the
//! weights the next batch is sampled with.

mod support;

use std::time::Duration;

use support::launch::{
    comparable, processes_with, run, signal, small_run, start, tiny_instance_file, until, wait, with,
};

#[test]
fn resume_after_a_killed_learner_matches_an_uninterrupted_run() {
    killed_and_resumed(0);
}

#[test]
fn a_lagged_run_resumed_after_a_killed_learner_matches_an_uninterrupted_run() {
    killed_and_resumed(1);
}

fn killed_and_resumed(lag: usize) {
    let dir = tempfile::tempdir().unwrap();
    let inst = tiny_instance_file(dir.path());
    let base = with(small_run(&inst, 9, 200), &["--lag", &lag.to_string()]);

    let reference = dir.path().join("reference.json");
    let o = run(
        &with(base.clone(), &["--in-process", "--out", &reference.display().to_string()]),
        Duration::from_secs(120),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));

    let run_dir = dir.path().join("run");
    let out = dir.path().join("resumed.json");
    let run_dir_s = run_dir.display().to_string();
    let args = with(
        base,
        &[
            "--workers",
            "2",
            "--emulator-cost-us",
            "100",
            "--checkpoint-every",
            "25",
            "--run-dir",
            &run_dir_s,
            "--out",
            &out.display().to_string(),
        ],
    );
    let child = start(&args);
    let checkpoint = run_dir.join("checkpoint.bin");
    until("a first checkpoint", Duration::from_secs(60), || checkpoint.exists());
    let learners = processes_with(&["envpg-launch", "learner", "--run-dir", &run_dir_s]);
    assert_eq!(learners.len(), 1, "{learners:?}");
    signal(learners[0].0, libc::SIGKILL);
    let o = wait(child, Duration::from_secs(60));
    assert!(!o.status.success(), "the supervisor must report the learner's death");
    assert!(!out.exists(), "no result from a killed run");
    // Every process of the run is gone.
    until("workers to stop", Duration::from_secs(10), || {
        processes_with(&["envpg-launch", "--run-dir", &run_dir_s]).is_empty()
    });

    let o = run(&["--resume".to_string(), run_dir_s.clone(), "--quiet".to_string()], Duration::from_secs(120));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (a, b) = (comparable(&out), comparable(&reference));
    if a != b {
        // Name the first difference instead of printing two whole result files.
        let first =
            a["history"].as_array().unwrap().iter().zip(b["history"].as_array().unwrap()).position(|(x, y)| x != y);
        let show = |v: &serde_json::Value| first.map(|i| v["history"][i].to_string()).unwrap_or_default();
        panic!(
            "lag {lag}: the resumed run differs from the uninterrupted one; first differing history row: {first:?}\nresumed:   {}\nreference: {}",
            show(&a),
            show(&b)
        );
    }
}
