//! The run's shared-memory segments are readable and writable by the owning user only, and a
//! SIGTERM to the launcher stops every process of the run (exit code 130) and leaves no
//! iceoryx2 node of the run behind, alive or dead (a dead node is what pins stale resources).

mod support;

use std::collections::BTreeSet;
use std::os::unix::fs::MetadataExt;
use std::time::Duration;

use iceoryx2::node::NodeView;
use iceoryx2::prelude::*;
use support::launch::{processes_with, signal, small_run, start, tiny_instance_file, until, wait, with};

fn shm_files() -> BTreeSet<String> {
    std::fs::read_dir("/dev/shm")
        .map(|d| {
            d.filter_map(|e| e.ok())
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .filter(|n| n.starts_with("iox2_"))
                .collect()
        })
        .unwrap_or_default()
}

#[test]
fn segments_are_owner_only_and_sigterm_stops_and_cleans_everything() {
    let dir = tempfile::tempdir().unwrap();
    let inst = tiny_instance_file(dir.path());
    let before = shm_files();
    let run_dir = dir.path().join("run");
    let run_dir_s = run_dir.display().to_string();
    let child = start(&with(
        small_run(&inst, 6, 2000),
        &[
            "--workers",
            "2",
            "--emulator-cost-us",
            "200",
            "--run-dir",
            &run_dir_s,
            "--out",
            &dir.path().join("o.json").display().to_string(),
        ],
    ));
    until("the run's workers", Duration::from_secs(30), || {
        processes_with(&["worker --run-dir", &run_dir_s]).len() == 2
    });
    let mut ours = BTreeSet::new();
    until("the run's shared memory", Duration::from_secs(30), || {
        ours = shm_files().difference(&before).cloned().collect();
        ours.len() >= 5
    });
    for name in &ours {
        let Ok(meta) = std::fs::metadata(format!("/dev/shm/{name}")) else { continue };
        let mode = meta.mode() & 0o777;
        assert_eq!(mode & 0o077, 0, "/dev/shm/{name} has mode {mode:o}: group or others can access it");
        assert_eq!(meta.uid(), unsafe { libc::getuid() }, "/dev/shm/{name} is not ours");
    }
    signal(child.id() as i32, libc::SIGTERM);
    let o = wait(child, Duration::from_secs(30));
    assert_eq!(o.status.code(), Some(130), "{}", String::from_utf8_lossy(&o.stderr));
    until("every process of the run to stop", Duration::from_secs(10), || {
        processes_with(&["--run-dir", &run_dir_s]).is_empty()
    });
    let run_id = serde_json::from_str::<serde_json::Value>(&std::fs::read_to_string(run_dir.join("run.json")).unwrap())
        .unwrap()["run_id"]
        .as_str()
        .unwrap()
        .to_owned();
    let mut left = Vec::new();
    let _ = Node::<ipc::Service>::list(Config::global_config(), |state| {
        let name = match &state {
            NodeState::Alive(v) => v.details().as_ref().map(|d| d.name().to_string()),
            NodeState::Dead(v) => v.details().as_ref().map(|d| d.name().to_string()),
            _ => None,
        };
        if let Some(n) = name.filter(|n| n.contains(&run_id)) {
            left.push(n);
        }
        CallbackProgression::Continue
    });
    assert!(left.is_empty(), "iceoryx2 nodes of the run left behind: {left:?}");
}
