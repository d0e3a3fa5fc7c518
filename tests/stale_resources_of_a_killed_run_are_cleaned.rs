//! A run killed with `kill -9` (supervisor, learner and workers) leaves iceoryx2 resources
//! behind; the next run starts cleanly, says what it removed, and finishes.

mod support;

use std::time::Duration;

use support::launch::{processes_with, run, signal, small_run, start, tiny_instance_file, until, with};

#[test]
fn next_run_removes_what_a_sigkilled_run_left_behind() {
    let dir = tempfile::tempdir().unwrap();
    let inst = tiny_instance_file(dir.path());
    let run_dir = dir.path().join("killed");
    let run_dir_s = run_dir.display().to_string();
    let args = with(
        small_run(&inst, 2, 400),
        &[
            "--workers",
            "2",
            "--emulator-cost-us",
            "200",
            "--run-dir",
            &run_dir_s,
            "--out",
            &dir.path().join("x.json").display().to_string(),
        ],
    );
    let mut child = start(&args);
    until("learner and workers to run", Duration::from_secs(30), || {
        processes_with(&["envpg-launch", "--run-dir", &run_dir_s]).len() >= 3
    });
    std::thread::sleep(Duration::from_millis(300));
    // kill -9 everything of the run at once: nobody gets to clean up.
    signal(child.id() as i32, libc::SIGKILL);
    for (pid, _) in processes_with(&["envpg-launch", "--run-dir", &run_dir_s]) {
        signal(pid, libc::SIGKILL);
    }
    let _ = child.wait();
    until("the killed run's processes to vanish", Duration::from_secs(10), || {
        processes_with(&["envpg-launch", "--run-dir", &run_dir_s]).is_empty()
    });

    let out = dir.path().join("next.json");
    let o = run(
        &with(small_run(&inst, 3, 20), &["--workers", "1", "--out", &out.display().to_string()]),
        Duration::from_secs(120),
    );
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    assert!(
        stderr.contains("removed the shared-memory resources of"),
        "the next run must say what it removed: {stderr}"
    );
    assert!(out.exists());
}
