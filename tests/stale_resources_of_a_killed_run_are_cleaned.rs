//! A run killed with `kill -9` (supervisor, learner and workers) leaves iceoryx2 resources
//! behind; the next run starts cleanly, says what it removed, and finishes — also when a
//! process died while creating a segment, which iceoryx2 would wait for without end.

mod support;

use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};
use std::time::Duration;

use iceoryx2::prelude::*;
use support::launch::{processes_with, run, signal, small_run, start, tiny_instance_file, until, with};

/// Starts a run in `run_dir` and kills all its processes with SIGKILL once they are running;
/// returns its run id.
fn start_and_kill(inst: &str, run_dir: &Path, out: &Path) -> String {
    let run_dir_s = run_dir.display().to_string();
    let args = with(
        small_run(inst, 2, 400),
        &["--workers", "2", "--emulator-cost-us", "200", "--run-dir", &run_dir_s, "--out", &out.display().to_string()],
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
    let run_file = std::fs::read_to_string(run_dir.join("run.json")).unwrap();
    serde_json::from_str::<serde_json::Value>(&run_file).unwrap()["run_id"].as_str().unwrap().to_owned()
}

#[test]
fn next_run_removes_what_a_sigkilled_run_left_behind() {
    let dir = tempfile::tempdir().unwrap();
    let inst = tiny_instance_file(dir.path());
    start_and_kill(&inst, &dir.path().join("killed"), &dir.path().join("x.json"));

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

/// The shared-memory files of the dynamic configs of the services of run `run_id`, found the way
/// iceoryx2 0.10 names them: each service's static config (`<root>/services/*.service`) holds
/// its name and unique id, and its dynamic config is `/dev/shm/<prefix>…_<id>.dynamic` with id
/// `unique_value << 64 | payload_value`.
fn dynamic_configs_of(run_id: &str) -> Vec<PathBuf> {
    let config = Config::global_config();
    let services = Path::new(config.global.root_path().as_string().to_string().as_str()).join("services");
    let mut ids = Vec::new();
    for entry in std::fs::read_dir(&services).unwrap().filter_map(|e| e.ok()) {
        let Ok(text) = std::fs::read_to_string(entry.path()) else { continue };
        if !text.contains(&format!("service_name = \"envpg/{run_id}/")) {
            continue;
        }
        let number = |key: &str| -> Option<u128> {
            text.lines().find_map(|l| l.trim().strip_prefix(key)?.trim().strip_prefix('=')?.trim().parse().ok())
        };
        if let (Some(payload), Some(unique)) = (number("payload_value"), number("unique_value")) {
            ids.push((unique << 64) | payload);
        }
    }
    std::fs::read_dir("/dev/shm")
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.path())
        .filter(|p| {
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            ids.iter().any(|id| name.ends_with(&format!("_{id}.dynamic")))
        })
        .collect()
}

/// A process killed between creating a segment and sizing it leaves an empty, write-only file;
/// iceoryx2 0.10 waits without end to open it while it cleans up the dead node, which hung
/// every later launch on the host. The next run removes it and finishes.
#[test]
fn a_run_after_one_killed_while_creating_shared_memory_does_not_hang() {
    let dir = tempfile::tempdir().unwrap();
    let inst = tiny_instance_file(dir.path());
    let run_id = start_and_kill(&inst, &dir.path().join("killed"), &dir.path().join("x.json"));
    // Put one of the dead run's dynamic configs in the state its creator leaves when killed
    // between creating and sizing it: empty and write-only.
    let configs = dynamic_configs_of(&run_id);
    let segment = configs.first().unwrap_or_else(|| panic!("no dynamic config of run {run_id} in /dev/shm"));
    std::fs::OpenOptions::new().write(true).truncate(true).open(segment).unwrap();
    std::fs::set_permissions(segment, std::fs::Permissions::from_mode(0o200)).unwrap();

    let out = dir.path().join("next.json");
    let o = run(
        &with(small_run(&inst, 3, 20), &["--workers", "1", "--out", &out.display().to_string()]),
        Duration::from_secs(60),
    );
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    // Removed (by this run, which then says so, or by a process of a test running beside it).
    assert!(!segment.exists(), "{} is still there", segment.display());
    assert!(out.exists());
}
