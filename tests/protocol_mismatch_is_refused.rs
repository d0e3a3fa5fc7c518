//! A worker speaking another protocol version is refused with an error naming both versions;
//! a run with good workers is not disturbed by it, and a run with only such workers fails
//! with that error instead of hanging.

mod support;

use std::time::Duration;

use envpg_protocol::PROTOCOL_VERSION;
use support::launch::{comparable, processes_with, run, small_run, start, tiny_instance_file, until, wait, with};

#[test]
fn a_foreign_worker_is_refused_and_the_run_is_not_corrupted() {
    let dir = tempfile::tempdir().unwrap();
    let inst = tiny_instance_file(dir.path());
    let base = small_run(&inst, 4, 150);
    let reference = dir.path().join("reference.json");
    let o = run(
        &with(base.clone(), &["--in-process", "--out", &reference.display().to_string()]),
        Duration::from_secs(120),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));

    let run_dir = dir.path().join("run");
    let run_dir_s = run_dir.display().to_string();
    let out = dir.path().join("out.json");
    let main = start(&with(
        base,
        &["--workers", "1", "--emulator-cost-us", "100", "--run-dir", &run_dir_s, "--out", &out.display().to_string()],
    ));
    until("the learner to start", Duration::from_secs(30), || {
        !processes_with(&["learner", "--run-dir", &run_dir_s]).is_empty()
    });
    let other = (PROTOCOL_VERSION + 7).to_string();
    let rogue = run(
        &["worker", "--run-dir", &run_dir_s, "--worker-id", "9", "--protocol-version", &other].map(String::from),
        Duration::from_secs(60),
    );
    let rogue_err = String::from_utf8_lossy(&rogue.stderr);
    assert_eq!(rogue.status.code(), Some(3), "{rogue_err}");
    assert!(
        rogue_err.contains(&format!("speaks protocol version {PROTOCOL_VERSION}"))
            && rogue_err.contains(&format!("speaks version {other}")),
        "{rogue_err}"
    );
    let o = wait(main, Duration::from_secs(120));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(comparable(&out), comparable(&reference), "the run must be unaffected by the refused worker");
}

#[test]
fn a_run_whose_workers_all_speak_another_version_fails_clearly() {
    let dir = tempfile::tempdir().unwrap();
    let inst = tiny_instance_file(dir.path());
    let other = (PROTOCOL_VERSION + 1).to_string();
    let o = run(
        &with(
            small_run(&inst, 4, 10),
            &[
                "--workers",
                "1",
                "--worker-protocol-version",
                &other,
                "--worker-timeout-ms",
                "300",
                "--out",
                &dir.path().join("o.json").display().to_string(),
            ],
        ),
        Duration::from_secs(60),
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains(&format!("protocol version {other}")) && err.contains(&format!("version {PROTOCOL_VERSION}")),
        "{err}"
    );
}
