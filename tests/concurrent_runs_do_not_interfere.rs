//! Two runs at once on one host, with different seeds, each finish with their own result
//! (equal to the same run done alone, in-process).

mod support;

use std::time::Duration;

use support::launch::{comparable, run, small_run, start, tiny_instance_file, wait, with};

#[test]
fn two_simultaneous_runs_get_their_own_results() {
    let dir = tempfile::tempdir().unwrap();
    let inst = tiny_instance_file(dir.path());
    let mut children = Vec::new();
    for seed in [21u64, 22] {
        let out = dir.path().join(format!("run{seed}.json"));
        children.push((
            seed,
            out.clone(),
            start(&with(small_run(&inst, seed, 120), &["--workers", "2", "--out", &out.display().to_string()])),
        ));
    }
    for (seed, out, child) in children {
        let o = wait(child, Duration::from_secs(180));
        assert!(o.status.success(), "seed {seed}: {}", String::from_utf8_lossy(&o.stderr));
        let reference = dir.path().join(format!("ref{seed}.json"));
        let r = run(
            &with(small_run(&inst, seed, 120), &["--in-process", "--out", &reference.display().to_string()]),
            Duration::from_secs(120),
        );
        assert!(r.status.success());
        assert_eq!(comparable(&out), comparable(&reference), "seed {seed}");
    }
}
