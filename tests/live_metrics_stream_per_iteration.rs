//! Live metrics: every run streams its per-iteration scalars to `metrics.csv` in its run
//! directory while it trains (a row per completed iteration, flushed as it happens), the same in
//! every execution mode and bit for bit the history of its result file; `--tensorboard DIR`
//! writes the same scalars as TensorBoard event files, read back here by the real `tensorboard`
//! Python package. Run directories default to `runs/<run id>/`, printed at the start, holding
//! the run's description, metrics, log, checkpoint and a copy of its result.

mod support;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

use support::launch::{assert_metrics_match_history, run, small_run, start, tiny_instance_file, wait, with};

/// Rows of a metrics CSV file: header, then (k, fields).
fn csv_rows(path: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let text = std::fs::read_to_string(path).unwrap_or_default();
    let mut lines = text.lines();
    let header = lines.next().map(|h| h.split(',').map(str::to_owned).collect()).unwrap_or_default();
    (header, lines.map(|l| l.split(',').map(str::to_owned).collect()).collect())
}

/// A Python that can import `tensorboard`: `$ENVPG_TEST_PYTHON`, the system `python3`, or a
/// virtual environment under the target directory with it installed from PyPI (once).
fn python_with_tensorboard() -> PathBuf {
    let imports =
        |py: &Path| Command::new(py).args(["-c", "import tensorboard"]).output().is_ok_and(|o| o.status.success());
    if let Some(p) = std::env::var_os("ENVPG_TEST_PYTHON") {
        let p = PathBuf::from(p);
        assert!(imports(&p), "$ENVPG_TEST_PYTHON ({}) cannot import tensorboard", p.display());
        return p;
    }
    if imports(Path::new("python3")) {
        return "python3".into();
    }
    let venv = Path::new(env!("CARGO_TARGET_TMPDIR")).join("tensorboard-venv");
    let py = venv.join("bin").join("python");
    if !imports(&py) {
        let ok = Command::new("python3").args(["-m", "venv"]).arg(&venv).status().is_ok_and(|s| s.success())
            && Command::new(&py)
                .args(["-m", "pip", "install", "--quiet", "--disable-pip-version-check", "tensorboard"])
                .status()
                .is_ok_and(|s| s.success());
        assert!(
            ok && imports(&py),
            "this test reads the event files with the `tensorboard` Python package: it could not be \
             installed into {} (no network?); `pip install tensorboard`, or point ENVPG_TEST_PYTHON at a \
             Python that has it",
            venv.display()
        );
    }
    py
}

/// Every scalar of the event files in `dir`, as TensorBoard reads them: tag → [(step, value)].
fn tensorboard_scalars(dir: &Path) -> serde_json::Value {
    let script = r#"
import json, sys
from tensorboard.backend.event_processing.event_accumulator import EventAccumulator
ea = EventAccumulator(sys.argv[1], size_guidance={"scalars": 0})
ea.Reload()
print(json.dumps({t: [[e.step, e.value] for e in ea.Scalars(t)] for t in ea.Tags()["scalars"]}))
"#;
    let o = Command::new(python_with_tensorboard()).args(["-c", script]).arg(dir).output().expect("python runs");
    assert!(o.status.success(), "reading the event files: {}", String::from_utf8_lossy(&o.stderr));
    serde_json::from_slice(&o.stdout).expect("the reader's JSON")
}

#[test]
fn metrics_stream_while_the_run_trains_and_tensorboard_reads_them_back() {
    let dir = tempfile::tempdir().unwrap();
    let inst = tiny_instance_file(dir.path());
    let iterations = 300;
    let (run_dir, out, tb) = (dir.path().join("run"), dir.path().join("r.json"), dir.path().join("tb"));
    let args = with(
        small_run(&inst, 3, iterations),
        &[
            "--workers",
            "2",
            "--emulator-cost-us",
            "100",
            "--run-dir",
            run_dir.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--tensorboard",
            tb.to_str().unwrap(),
        ],
    );
    let mut child = start(&args);
    // While it trains, the file already holds whole rows of the iterations done so far.
    let csv = run_dir.join("metrics.csv");
    let mut seen_while_running = None;
    while child.try_wait().unwrap().is_none() {
        let (header, rows) = csv_rows(&csv);
        if !rows.is_empty() && rows.len() < iterations {
            assert!(rows.iter().all(|r| r.len() == header.len()), "only whole rows: {rows:?}");
            seen_while_running = Some(rows.len());
            break;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    let o = wait(child, Duration::from_secs(180));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let n = seen_while_running.expect("metrics.csv had rows while the run was still training");
    eprintln!("{n} of {iterations} rows while training");
    assert_metrics_match_history(&run_dir, &out);
    // The run directory keeps everything: its description, log, checkpoint and the result.
    for f in ["run.json", "metrics.csv", "log.txt", "checkpoint.bin", "result.json"] {
        assert!(run_dir.join(f).exists(), "{f} in the run directory");
    }
    assert_eq!(std::fs::read(run_dir.join("result.json")).unwrap(), std::fs::read(&out).unwrap());

    // TensorBoard reads the same scalars (as f32) at the same steps.
    let scalars = tensorboard_scalars(&tb);
    let (header, rows) = csv_rows(&csv);
    for (c, tag) in header.iter().enumerate().skip(1) {
        let expected: Vec<(u64, f64)> = rows
            .iter()
            .filter_map(|r| {
                let v = r[c].parse::<f64>().ok().filter(|v| v.is_finite())?;
                Some((r[0].parse().unwrap(), f64::from(v as f32)))
            })
            .collect();
        let got: Vec<(u64, f64)> = scalars[tag.as_str()]
            .as_array()
            .map(|a| a.iter().map(|p| (p[0].as_u64().unwrap(), p[1].as_f64().unwrap())).collect())
            .unwrap_or_default();
        assert_eq!(got, expected, "tag {tag}");
    }
    assert!(scalars["J_exact"].as_array().is_some_and(|a| !a.is_empty()), "exact J points: {scalars}");

    // In one process, the same run writes the same metrics (timings aside).
    let (run_dir2, out2) = (dir.path().join("run2"), dir.path().join("r2.json"));
    let o = run(
        &with(
            small_run(&inst, 3, iterations),
            &["--in-process", "--run-dir", run_dir2.to_str().unwrap(), "--out", out2.to_str().unwrap()],
        ),
        Duration::from_secs(180),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_metrics_match_history(&run_dir2, &out2);
    let untimed = |rows: Vec<Vec<String>>, header: &[String]| -> Vec<Vec<String>> {
        let keep: Vec<usize> =
            (0..header.len()).filter(|&i| !matches!(header[i].as_str(), "transitions_per_s" | "seconds")).collect();
        rows.into_iter().map(|r| keep.iter().map(|&i| r[i].clone()).collect()).collect()
    };
    let (h2, rows2) = csv_rows(&run_dir2.join("metrics.csv"));
    assert_eq!(h2, header);
    assert_eq!(untimed(rows2, &h2), untimed(rows, &header));
}

#[test]
fn run_directories_go_under_runs_by_default_and_are_printed_at_the_start() {
    let dir = tempfile::tempdir().unwrap();
    let inst = tiny_instance_file(dir.path());
    let mut args = small_run(&inst, 1, 5);
    args.retain(|a| a != "--quiet");
    let o = Command::new(support::launch::binary())
        .args(&args)
        .args(["--in-process", "--out", "r.json"])
        .env_remove("ENVPG_RUNS_DIR")
        .current_dir(dir.path())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    let line = err.lines().next().expect("a first line");
    let printed = line.strip_prefix("run directory: ").unwrap_or_else(|| panic!("printed first: {err}"));
    let runs = dir.path().canonicalize().unwrap().join("runs");
    let entries: Vec<PathBuf> = std::fs::read_dir(&runs).unwrap().map(|e| e.unwrap().path()).collect();
    assert_eq!(entries.len(), 1, "{entries:?}");
    assert_eq!(Path::new(printed).canonicalize().unwrap(), entries[0].canonicalize().unwrap());
    let id = entries[0].file_name().unwrap().to_str().unwrap().to_owned();
    assert!(id.len() == 12 && id.chars().all(|c| c.is_ascii_hexdigit()), "named by the run id: {id}");
    for f in ["run.json", "metrics.csv", "checkpoint.bin", "result.json"] {
        assert!(entries[0].join(f).exists(), "{f} in {}", entries[0].display());
    }

    // ENVPG_RUNS_DIR moves the default; --run-dir overrides both.
    let elsewhere = dir.path().join("elsewhere");
    let o = Command::new(support::launch::binary())
        .args(small_run(&inst, 1, 5))
        .args(["--in-process", "--out", "r.json"])
        .env("ENVPG_RUNS_DIR", &elsewhere)
        .current_dir(dir.path())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(std::fs::read_dir(&elsewhere).unwrap().count(), 1);
    assert_eq!(std::fs::read_dir(&runs).unwrap().count(), 1, "nothing new under ./runs");

    // An unwritable --tensorboard is bad input, found before training.
    let o = run(
        &with(small_run(&inst, 1, 100_000), &["--in-process", "--tensorboard", "/proc/nope"]),
        Duration::from_secs(60),
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("--tensorboard /proc/nope"), "{err}");
}
