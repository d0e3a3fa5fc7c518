//! A worker killed with SIGKILL at a random moment: the learner notices (heartbeat timeout),
//! the supervisor starts a replacement, the unfinished episodes are regenerated from the same
//! streams, and the final result is bitwise identical to an undisturbed run.

mod support;

use std::time::Duration;

use support::launch::{comparable, run, run_killing_worker_zero, small_run, tiny_instance_file, with};

#[test]
fn sigkilled_worker_changes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let inst = tiny_instance_file(dir.path());
    let base = small_run(&inst, 5, 300);

    let reference = dir.path().join("reference.json");
    let o = run(
        &with(base.clone(), &["--in-process", "--out", &reference.display().to_string()]),
        Duration::from_secs(120),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));

    let run_dir = dir.path().join("run");
    let out = dir.path().join("killed.json");
    let args = with(
        base,
        &[
            "--workers",
            "2",
            "--emulator-cost-us",
            "150",
            "--worker-timeout-ms",
            "400",
            "--run-dir",
            &run_dir.display().to_string(),
            "--out",
            &out.display().to_string(),
        ],
    );
    let o = run_killing_worker_zero(&args, &run_dir, 1500, Duration::from_secs(240));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    assert!(stderr.contains("worker 0 exited (signal 9); starting a replacement"), "{stderr}");
    assert_eq!(comparable(&out), comparable(&reference), "the disturbed run must equal the undisturbed one");
    // Every episode of every iteration was used exactly once (late copies are dropped).
    let r: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!(r["details"]["link"]["episodes"], 300 * 24, "{}", r["details"]["link"]);
}
