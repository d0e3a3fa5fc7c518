//! Nothing computed is lost: an output that cannot be written is refused before training
//! (exit 2), and SIGINT at a random moment (to the launcher, with worker processes and
//! in-process) or SIGTERM to the learner process alone checkpoints the last completed iteration,
//! prints the command that continues the run, and `--resume DIR` ends bitwise identical to an
//! uninterrupted run. A corrupt or foreign checkpoint is
//! refused with exit 2.

mod support;

use std::path::Path;
use std::time::{Duration, Instant};

use support::launch::{
    assert_metrics_match_history, comparable, processes_with, run, signal, small_run, start, tiny_instance_file, until,
    wait, with,
};

#[test]
fn an_unwritable_output_is_refused_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let inst = tiny_instance_file(dir.path());
    let run_dir = dir.path().join("run");
    let started = Instant::now();
    let o = run(
        &with(
            small_run(&inst, 1, 100_000),
            &["--in-process", "--out", "/proc/nope/r.json", "--run-dir", &run_dir.display().to_string()],
        ),
        Duration::from_secs(60),
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("/proc/nope/r.json"), "{err}");
    // 100,000 iterations would take minutes: the refusal came before training.
    assert!(!run_dir.join("run.json").exists(), "no run was started");
    eprintln!("refused after {:?}", started.elapsed());
    let o = run(&with(small_run(&inst, 1, 10), &["--run-dir", "/proc/nope"]), Duration::from_secs(60));
    assert_eq!(o.status.code(), Some(2), "{}", String::from_utf8_lossy(&o.stderr));
}

/// A pseudo-random delay in `[lo, hi)` ms, different on every call (the interrupt lands at a
/// different iteration every time the test runs).
fn random_delay(lo: u64, hi: u64) -> Duration {
    use std::hash::BuildHasher;
    let r = std::collections::hash_map::RandomState::new().hash_one(Instant::now());
    Duration::from_millis(lo + r % (hi - lo))
}

/// Who gets the signal.
#[derive(Debug, Clone, Copy)]
enum Target {
    /// SIGINT to `envpg-launch`.
    Launcher,
    /// SIGTERM to the learner process alone.
    Learner,
}

fn interrupt_then_resume(mode: &[&str], target: Target, dir: &Path, reference: &serde_json::Value, base: &[String]) {
    let tag = format!("{}-{target:?}", mode.len());
    let run_dir = dir.join(format!("run{tag}"));
    let out = dir.join(format!("out{tag}.json"));
    let run_dir_s = run_dir.display().to_string();
    let mut extra = vec!["--run-dir", &run_dir_s];
    let out_s = out.display().to_string();
    extra.extend(["--out", &out_s]);
    extra.extend(mode);
    let child = start(&with(base.to_vec(), &extra));
    until("the run to start", Duration::from_secs(60), || run_dir.join("run.json").exists());
    std::thread::sleep(random_delay(300, 1500));
    match target {
        Target::Launcher => signal(child.id() as i32, libc::SIGINT),
        Target::Learner => {
            let learners = processes_with(&["learner --run-dir", &run_dir_s]);
            assert_eq!(learners.len(), 1, "{learners:?}");
            signal(learners[0].0, libc::SIGTERM);
        }
    }
    let o = wait(child, Duration::from_secs(120));
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(130), "{err}");
    eprintln!("{mode:?} {target:?}: {}", err.lines().find(|l| l.starts_with("kept:")).unwrap_or("no checkpoint line"));
    assert!(err.contains(&format!("--resume {run_dir_s}")), "the resume command is printed: {err}");
    assert!(!out.exists(), "no result from an interrupted run");
    let o = run(&["--resume".into(), run_dir_s.clone(), "--quiet".into()], Duration::from_secs(120));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(&comparable(&out) == reference, "{mode:?}: the resumed run differs from the uninterrupted one ({err})");
    // The live metrics of both parts read as one run.
    assert_metrics_match_history(&run_dir, &out);

    // The checkpoint is now the end of training. Corrupt it: --resume refuses, exit 2.
    let cp = run_dir.join("checkpoint.bin");
    let mut bytes = std::fs::read(&cp).unwrap();
    let n = bytes.len();
    bytes[n / 2] ^= 0x10;
    std::fs::write(&cp, &bytes).unwrap();
    let o = run(&["--resume".into(), run_dir_s.clone()], Duration::from_secs(60));
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("checksum") && err.contains("checkpoint.bin"), "{err}");
    std::fs::write(&cp, &bytes[..n / 3]).unwrap();
    let o = run(&["--resume".into(), run_dir_s], Duration::from_secs(60));
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("truncated"), "{err}");
}

#[test]
fn sigint_checkpoints_and_resume_ends_with_the_uninterrupted_result() {
    let dir = tempfile::tempdir().unwrap();
    let inst = tiny_instance_file(dir.path());
    let base = with(small_run(&inst, 4, 2000), &["--emulator-cost-us", "50"]);
    let reference = dir.path().join("reference.json");
    let o = run(
        &with(base.clone(), &["--in-process", "--out", &reference.display().to_string()]),
        Duration::from_secs(120),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let reference = comparable(&reference);
    interrupt_then_resume(&["--workers", "2"], Target::Launcher, dir.path(), &reference, &base);
    interrupt_then_resume(&["--workers", "2", "--in-process"], Target::Launcher, dir.path(), &reference, &base);
    interrupt_then_resume(&["--workers", "2"], Target::Learner, dir.path(), &reference, &base);
}

#[test]
fn a_checkpoint_of_another_run_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let inst = tiny_instance_file(dir.path());
    let mut dirs = Vec::new();
    for seed in [1, 2] {
        let d = dir.path().join(format!("run{seed}"));
        let o = run(
            &with(
                small_run(&inst, seed, 5),
                &[
                    "--in-process",
                    "--run-dir",
                    &d.display().to_string(),
                    "--out",
                    &dir.path().join(format!("{seed}.json")).display().to_string(),
                ],
            ),
            Duration::from_secs(60),
        );
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        dirs.push(d);
    }
    std::fs::copy(dirs[0].join("checkpoint.bin"), dirs[1].join("checkpoint.bin")).unwrap();
    let o = run(&["--resume".into(), dirs[1].display().to_string()], Duration::from_secs(60));
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("does not belong to this run"), "{err}");
}
