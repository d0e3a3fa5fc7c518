//! Running the `envpg-launch` binary from tests, with watchdog timeouts.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

/// The built `envpg-launch` next to this test executable (target/<profile>/).
pub fn binary() -> PathBuf {
    let exe = std::env::current_exe().expect("test executable");
    let dir = exe.parent().and_then(Path::parent).expect("target/<profile>");
    let bin = dir.join("envpg-launch");
    assert!(bin.exists(), "{} is not built (the test command builds every workspace binary)", bin.display());
    bin
}

/// Starts `envpg-launch` with `args`.
pub fn start(args: &[String]) -> Child {
    Command::new(binary())
        .args(args)
        // Default run directories (runs/<id>) stay out of the source tree.
        .env("ENVPG_RUNS_DIR", std::env::temp_dir().join("envpg-test-runs"))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("envpg-launch starts")
}

/// Waits for `child` with a watchdog: kills it and panics after `limit`.
pub fn wait(mut child: Child, limit: Duration) -> Output {
    let start = Instant::now();
    loop {
        if child.try_wait().expect("wait").is_some() {
            return child.wait_with_output().expect("output");
        }
        if start.elapsed() > limit {
            let _ = child.kill();
            let out = child.wait_with_output().expect("output");
            panic!(
                "watchdog: envpg-launch still running after {limit:?}\nstderr:\n{}",
                String::from_utf8_lossy(&out.stderr)
            );
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Runs `envpg-launch` to completion under a watchdog.
pub fn run(args: &[String], limit: Duration) -> Output {
    wait(start(args), limit)
}

/// Processes whose command line contains every needle, as (pid, command line).
pub fn processes_with(needles: &[&str]) -> Vec<(i32, String)> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir("/proc").expect("/proc") {
        let Ok(entry) = entry else { continue };
        let Ok(pid) = entry.file_name().to_string_lossy().parse::<i32>() else { continue };
        let Ok(raw) = std::fs::read(entry.path().join("cmdline")) else { continue };
        let cmd = String::from_utf8_lossy(&raw).replace('\0', " ");
        if needles.iter().all(|n| cmd.contains(n)) {
            out.push((pid, cmd));
        }
    }
    out
}

/// Polls until `f` is true, panicking after `limit`.
pub fn until(what: &str, limit: Duration, mut f: impl FnMut() -> bool) {
    let start = Instant::now();
    while !f() {
        assert!(start.elapsed() < limit, "watchdog: {what} did not happen within {limit:?}");
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// Starts `args` (a run with `--workers` and `--run-dir run_dir`), SIGKILLs worker 0 at a
/// random moment 200 ms to 200 + `window_ms` ms after it started, and waits for the run under a
/// watchdog of `limit`.
pub fn run_killing_worker_zero(args: &[String], run_dir: &Path, window_ms: u64, limit: Duration) -> Output {
    let child = start(args);
    let dir = run_dir.display().to_string();
    let workers = || processes_with(&["envpg-launch", "worker", "--run-dir", &dir, "--worker-id 0"]);
    until("worker 0 to start", Duration::from_secs(30), || !workers().is_empty());
    let nanos = Instant::now().elapsed().as_nanos() as u64 ^ u64::from(std::process::id());
    std::thread::sleep(Duration::from_millis(200 + nanos % window_ms));
    let victims = workers();
    assert_eq!(victims.len(), 1, "{victims:?}");
    signal(victims[0].0, libc::SIGKILL);
    wait(child, limit)
}

/// Sends `sig` to `pid`.
pub fn signal(pid: i32, sig: i32) {
    // SAFETY: kill(2) on a pid of our test's own processes.
    unsafe {
        libc::kill(pid, sig);
    }
}

/// A tiny instance file in `dir`, returned as a path string.
pub fn tiny_instance_file(dir: &Path) -> String {
    let inst = super::tiny_instance(20, 3, 5);
    let p = dir.join("tiny.json");
    std::fs::write(&p, inst.to_json_pretty()).unwrap();
    p.display().to_string()
}

/// The common options of a small, quick training run on `instance`.
pub fn small_run(instance: &str, seed: u64, iterations: usize) -> Vec<String> {
    [
        "--instance",
        instance,
        "--seed",
        &seed.to_string(),
        "--kappa",
        "0.9",
        "--iterations",
        &iterations.to_string(),
        "--episodes",
        "16",
        "--explore-episodes",
        "8",
        "--hidden",
        "32",
        "--batch",
        "128",
        "--warmup",
        "20",
        "--eval-every",
        "20",
        "--polish-iterations",
        "3",
        "--polish-episodes",
        "64",
        "--polish-policy-rounds",
        "1",
        "--polish-policy-samples",
        "64",
        "--polish-candidates",
        "2",
        "--polish-screen",
        "2",
        "--quiet",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect()
}

/// A result file without its timing fields, for bitwise comparisons.
pub fn comparable(path: &Path) -> serde_json::Value {
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(path).expect("result file")).expect("json");
    v["seconds"] = serde_json::Value::Null;
    v["details"] = serde_json::Value::Null;
    v
}

/// Args plus extras.
pub fn with(mut base: Vec<String>, extra: &[&str]) -> Vec<String> {
    base.extend(extra.iter().map(|s| s.to_string()));
    base
}

/// Checks `DIR/metrics.csv` of a finished run against its result file `out`: one row per
/// iteration, k = 0, 1, … in order, each once, with α, the J_H estimate and the exact J of the
/// result's history, bit for bit.
pub fn assert_metrics_match_history(run_dir: &Path, out: &Path) {
    let text = std::fs::read_to_string(run_dir.join("metrics.csv")).expect("metrics.csv");
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().expect("a header").split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap_or_else(|| panic!("no {name} in {header:?}"));
    let (alpha, j_h, j) = (col("alpha"), col("J_H_estimate"), col("J_exact"));
    let r: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(out).unwrap()).unwrap();
    let history = r["history"].as_array().expect("history");
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), history.len(), "one row per iteration:\n{text}");
    for (row, h) in rows.iter().zip(history) {
        assert_eq!(row.len(), header.len(), "{row:?}");
        assert_eq!(row[0].parse::<u64>().unwrap(), h["k"].as_u64().unwrap(), "rows in iteration order");
        assert_eq!(row[alpha].parse::<f64>().unwrap(), h["alpha"].as_f64().unwrap(), "k = {}", row[0]);
        assert_eq!(row[j_h].parse::<f64>().unwrap(), h["j_h_estimate"].as_f64().unwrap(), "k = {}", row[0]);
        assert_eq!(row[j].parse::<f64>().ok(), h["J_exact"].as_f64(), "k = {}", row[0]);
    }
}
