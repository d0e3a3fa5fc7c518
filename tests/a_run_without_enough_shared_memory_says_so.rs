//! A run whose shared memory does not fit in `/dev/shm` (tmpfs faults with SIGBUS when it is
//! full — Docker's default is 64 MB) ends with an input error that says where the memory ran
//! out, how full it is and what to do, exit 2 — not a crash report. The test gives the run a
//! private, tiny `/dev/shm` in a mount namespace (`unshare -m`, needs root; where that is not
//! permitted it says so and checks nothing else).

mod support;

use std::process::Command;
use std::time::{Duration, Instant};

use support::launch::{binary, small_run, tiny_instance_file};

#[test]
fn a_full_dev_shm_is_an_input_error_naming_it() {
    let permitted = Command::new("unshare")
        .args(["-m", "sh", "-c", "mount -t tmpfs -o size=64k tmpfs /dev/shm"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !permitted {
        eprintln!("NOTE: mount namespaces are not available here (needs root and util-linux's unshare); not tested");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let inst = tiny_instance_file(dir.path());
    let mut args = small_run(&inst, 1, 50);
    args.extend(["--workers", "2", "--run-dir"].iter().map(|s| s.to_string()));
    args.push(dir.path().join("run").display().to_string());
    let script = format!(
        "mount -t tmpfs -o size=64k tmpfs /dev/shm && exec {} {}",
        binary().display(),
        args.iter().map(|a| format!("'{a}'")).collect::<Vec<_>>().join(" ")
    );
    let mut child =
        Command::new("unshare").args(["-m", "sh", "-c", &script]).stderr(std::process::Stdio::piped()).spawn().unwrap();
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > Duration::from_secs(120) {
            let _ = child.kill();
            panic!("watchdog: the run with a tiny /dev/shm still running after 120 s");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let o = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("shared memory in /dev/shm ran out") && err.contains("MiB free of"), "{err}");
    assert!(err.contains("--shm-size") && err.contains("--in-process"), "says what to do: {err}");
}
