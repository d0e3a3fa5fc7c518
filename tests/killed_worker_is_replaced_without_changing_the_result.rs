//! A worker killed with SIGKILL at a random moment: the learner notices (heartbeat timeout),
//! the supervisor starts a replacement, the unfinished episodes are regenerated from the same
//! streams, and the final result is bitwise identical to an undisturbed run.

mod support;

use std::time::{Duration, Instant};

use support::launch::{
    comparable, processes_with, run, signal, small_run, start, tiny_instance_file, until, wait, with,
};

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
    let child = start(&args);
    let dir_s = run_dir.display().to_string();
    let workers = || processes_with(&["envpg-launch", "worker", "--run-dir", &dir_s, "--worker-id 0"]);
    until("worker 0 to start", Duration::from_secs(30), || !workers().is_empty());
    // A random moment within the run.
    let nanos = Instant::now().elapsed().as_nanos() as u64 ^ u64::from(std::process::id());
    std::thread::sleep(Duration::from_millis(200 + nanos % 1500));
    let victims = workers();
    assert_eq!(victims.len(), 1, "{victims:?}");
    signal(victims[0].0, libc::SIGKILL);
    let o = wait(child, Duration::from_secs(240));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    assert!(stderr.contains("worker 0 exited (signal 9); starting a replacement"), "{stderr}");
    assert_eq!(comparable(&out), comparable(&reference), "the disturbed run must equal the undisturbed one");
    // Every episode of every iteration was used exactly once (late copies are dropped).
    let r: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!(r["details"]["link"]["episodes"], 300 * 24, "{}", r["details"]["link"]);
}
