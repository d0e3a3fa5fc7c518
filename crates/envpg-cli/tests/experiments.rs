//! `envpg table`, `plot` and `sweep` on a tiny instance with a tiny budget: well-formed
//! tables (parsed), figures (SVG parsed as XML, PNG of the SVG's size), result files that
//! re-score to their J, resuming without redoing finished runs, and refusing to mix settings.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::{Duration, Instant, SystemTime};

/// Runs `envpg` with a watchdog.
fn envpg(args: &[&str]) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_envpg"))
        .args(args)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("envpg starts");
    let start = Instant::now();
    while child.try_wait().expect("wait").is_none() {
        if start.elapsed() > Duration::from_secs(300) {
            let _ = child.kill();
            panic!("watchdog: envpg {args:?} still running after 300 s");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().expect("output")
}

fn ok(o: &Output) -> String {
    assert!(o.status.success(), "exit {:?}\nstdout:\n{}\nstderr:\n{}", o.status, text(&o.stdout), text(&o.stderr));
    text(&o.stdout)
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

fn tiny_instance(dir: &Path) -> String {
    let path = dir.join("tiny.json");
    ok(&envpg(&[
        "instance",
        "generate",
        "--users",
        "30",
        "--uavs",
        "3",
        "--clusters",
        "3",
        "--seed",
        "2",
        "--out",
        path.to_str().unwrap(),
    ]));
    path.to_str().unwrap().to_owned()
}

/// Parses an SVG as XML and checks that the PNG beside it is an image of the same size.
fn check_figure(dir: &Path, stem: &str) {
    let svg = std::fs::read_to_string(dir.join(format!("{stem}.svg"))).expect("svg written");
    let doc = roxmltree::Document::parse(&svg).unwrap_or_else(|e| panic!("{stem}.svg is not XML: {e}"));
    let root = doc.root_element();
    assert_eq!(root.tag_name().name(), "svg");
    let dim = |a: &str| root.attribute(a).and_then(|v| v.parse::<u32>().ok()).expect("svg size");
    let (w, h) = (dim("width"), dim("height"));
    assert!(doc.descendants().any(|n| n.tag_name().name() == "text"), "{stem}.svg has no text");
    let png = std::fs::read(dir.join(format!("{stem}.png"))).expect("png written");
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n", "{stem}.png signature");
    assert_eq!(&png[12..16], b"IHDR");
    let be = |i: usize| u32::from_be_bytes(png[i..i + 4].try_into().unwrap());
    assert_eq!((be(16), be(20)), (w, h), "{stem}.png size differs from the SVG's");
}

/// `table.csv` as rows of column → value, checking every row has every column.
fn read_csv(path: &Path) -> Vec<BTreeMap<String, String>> {
    read_csv_text(&std::fs::read_to_string(path).expect("csv written"))
}

fn read_csv_text(text: &str) -> Vec<BTreeMap<String, String>> {
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().expect("header").split(',').collect();
    lines
        .map(|l| {
            let cells: Vec<&str> = l.split(',').collect();
            assert_eq!(cells.len(), header.len(), "row {l:?}");
            header.iter().zip(cells).map(|(h, c)| (h.to_string(), c.to_string())).collect()
        })
        .collect()
}

/// The markdown table's rows as cells, checking they all have the header's width.
fn read_markdown_table(path: &Path) -> Vec<Vec<String>> {
    let text = std::fs::read_to_string(path).expect("markdown written");
    let rows: Vec<Vec<String>> = text
        .lines()
        .filter(|l| l.starts_with('|'))
        .map(|l| l.trim_matches('|').split('|').map(|c| c.trim().to_owned()).collect())
        .collect();
    assert!(rows.len() >= 3, "no table in {text}");
    for r in &rows {
        assert_eq!(r.len(), rows[0].len(), "ragged row {r:?}");
    }
    rows
}

fn mtimes(dir: &Path) -> BTreeMap<PathBuf, SystemTime> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "json"))
        .map(|p| (p.clone(), std::fs::metadata(&p).unwrap().modified().unwrap()))
        .collect()
}

fn table_args<'a>(instance: &'a str, out: &'a str) -> Vec<&'a str> {
    vec![
        "table",
        "--instance",
        instance,
        "--kappas",
        "1,0.9",
        "--seeds",
        "1..2",
        "--preset",
        "smoke",
        "--restarts",
        "2",
        "--jobs",
        "2",
        "--window",
        "5",
        "--quiet",
        "--out",
        out,
    ]
}

#[test]
fn table_writes_parsable_reports_and_resumes_without_redoing_runs() {
    let tmp = tempfile::tempdir().unwrap();
    let instance = tiny_instance(tmp.path());
    let out_dir = tmp.path().join("table");
    let out = out_dir.to_str().unwrap();
    let stdout = ok(&envpg(&table_args(&instance, out)));
    assert!(stdout.contains("Table I"), "{stdout}");

    // table.csv: 2 κ × 2 seeds × (Algorithm 1 + same-start oracle) + 2 best oracles.
    let rows = read_csv(&out_dir.join("table.csv"));
    assert_eq!(rows.len(), 10);
    let count = |m: &str| rows.iter().filter(|r| r["method"] == m).count();
    assert_eq!((count("algorithm1"), count("oracle-same-start"), count("oracle-best")), (4, 4, 2));
    for r in &rows {
        let j: f64 = r["J"].parse().unwrap_or_else(|_| panic!("J of {r:?}"));
        assert!(j.is_finite() && j > 0.0);
        assert!(r["seconds"].parse::<f64>().is_ok());
        if r["method"] == "algorithm1" {
            assert_eq!(r["iterations"], "30", "{r:?}");
            assert!(r["transitions"].parse::<u64>().unwrap() > 0);
        }
        // Every J re-scores from its own result file.
        let file = out_dir.join(&r["file"]);
        let o = envpg(&["evaluate", file.to_str().unwrap()]);
        ok(&o);
    }
    // The best oracle is no worse than any same-start oracle at its κ (it has more restarts
    // or the same J): the relation the table's Δ rows rely on.
    let md = read_markdown_table(&out_dir.join("table.md"));
    assert_eq!(md[0][1..], ["kappa = 1", "kappa = 0.9", "overall"]);
    let names: Vec<&str> = md.iter().map(|r| r[0].as_str()).collect();
    for want in [
        "Algorithm 1 alone",
        "Algorithm 1 + polish",
        "Oracle, same ζ₀",
        "Oracle, best of 2 restarts",
        "Δ Algorithm 1 alone vs same-ζ₀ oracle",
        "Δ Algorithm 1 + polish vs same-ζ₀ oracle",
    ] {
        assert!(names.contains(&want), "{names:?}");
    }
    for row in ["Algorithm 1 alone", "Algorithm 1 + polish"] {
        let alg1 = &md[names.iter().position(|n| *n == row).unwrap()];
        for cell in &alg1[1..3] {
            let (m, s) = cell.split_once(" ± ").unwrap_or_else(|| panic!("mean ± std cell {cell:?}"));
            assert!(m.parse::<f64>().is_ok() && s.parse::<f64>().is_ok(), "{cell}");
        }
    }
    let delta = &md[names.iter().position(|n| n.starts_with("Δ Algorithm 1 + polish vs same")).unwrap()];
    for cell in &delta[1..] {
        assert!(cell.ends_with('%') && cell.trim_end_matches('%').parse::<f64>().is_ok(), "{cell}");
    }
    // Algorithm 1 alone is the exact J of the design before the polish, stored with its policy.
    for r in rows.iter().filter(|r| r["method"] == "algorithm1") {
        let result: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out_dir.join(&r["file"])).unwrap()).unwrap();
        let polish = &result["details"]["polish"];
        assert_eq!(polish["J_before"].as_f64().unwrap().to_string(), r["J_alone"], "{r:?}");
        assert!(polish["policy_before"].is_array() && polish["zeta_before"].is_array());
    }
    for stem in ["designs", "grad_norm", "learning_curves", "trajectories"] {
        check_figure(&out_dir, stem);
    }

    // Resume: nothing is rerun, the report is the same.
    let runs = out_dir.join("runs");
    let before = mtimes(&runs);
    assert_eq!(before.len(), 10);
    let csv_before = std::fs::read_to_string(out_dir.join("table.csv")).unwrap();
    let o = envpg(&table_args(&instance, out));
    ok(&o);
    assert_eq!(mtimes(&runs), before, "finished runs were redone");
    assert_eq!(std::fs::read_to_string(out_dir.join("table.csv")).unwrap(), csv_before);

    // An interrupted table: one run missing is the only one redone.
    let missing = runs.join("algorithm1_kappa0.9_s2.json");
    std::fs::remove_file(&missing).unwrap();
    ok(&envpg(&table_args(&instance, out)));
    let after = mtimes(&runs);
    for (path, t) in &before {
        if *path != missing {
            assert_eq!(after[path], *t, "{} was redone", path.display());
        }
    }
    // Same seed, same result: every column but the wall-clock time.
    let without_time = |rows: Vec<BTreeMap<String, String>>| {
        rows.into_iter()
            .map(|mut r| {
                r.remove("seconds");
                r
            })
            .collect::<Vec<_>>()
    };
    assert_eq!(
        without_time(read_csv(&out_dir.join("table.csv"))),
        without_time(read_csv_text(&csv_before)),
        "same seed, same result"
    );

    // Other settings in the same directory are refused, not mixed.
    let mut other = table_args(&instance, out);
    other.extend(["--set", "sigma=0.1"]);
    let o = envpg(&other);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o.stderr));
    assert!(text(&o.stderr).contains("other settings"), "{}", text(&o.stderr));
}

#[test]
fn table_runs_distributed_with_the_same_results() {
    let tmp = tempfile::tempdir().unwrap();
    let instance = tiny_instance(tmp.path());
    let run = |mode: &[&str], name: &str| {
        let dir = tmp.path().join(name);
        let mut args = vec![
            "table",
            "--instance",
            &instance,
            "--kappas",
            "1",
            "--seeds",
            "3",
            "--preset",
            "smoke",
            "--restarts",
            "1",
            "--quiet",
            "--out",
            dir.to_str().unwrap(),
        ];
        args.extend(mode);
        ok(&envpg(&args));
        let rows = read_csv(&dir.join("table.csv"));
        rows.into_iter().find(|r| r["method"] == "algorithm1").unwrap()["J"].clone()
    };
    let local = run(&["--in-process"], "local");
    let distributed = run(&["--workers", "1"], "distributed");
    assert_eq!(local, distributed);
}

#[test]
fn plot_renders_every_figure_of_given_results() {
    let tmp = tempfile::tempdir().unwrap();
    let instance = tiny_instance(tmp.path());
    let table = tmp.path().join("t");
    let mut args = table_args(&instance, table.to_str().unwrap());
    args[4] = "1";
    ok(&envpg(&args));
    let runs = table.join("runs");
    let figs = tmp.path().join("figs");
    let files: Vec<String> = ["algorithm1_kappa1_s1.json", "algorithm1_kappa1_s2.json", "oracle-best_kappa1.json"]
        .iter()
        .map(|f| runs.join(f).to_str().unwrap().to_owned())
        .collect();
    let mut args = vec!["plot", "--out", figs.to_str().unwrap(), "--window", "3"];
    args.extend(files.iter().map(String::as_str));
    let stdout = ok(&envpg(&args));
    for stem in ["designs", "grad_norm", "learning_curves", "trajectories"] {
        assert!(stdout.contains(&format!("{stem}.png")), "{stdout}");
        check_figure(&figs, stem);
    }
    // Oracle results alone still give the designs figure.
    let only = tmp.path().join("only");
    ok(&envpg(&["plot", "--out", only.to_str().unwrap(), &files[2]]));
    check_figure(&only, "designs");
    assert!(!only.join("grad_norm.svg").exists());

    // Bad input: a file that is not a result, and a zero window.
    let bogus = tmp.path().join("bogus.json");
    std::fs::write(&bogus, "{\"schema\": \"nope\"}").unwrap();
    let o = envpg(&["plot", "--out", only.to_str().unwrap(), bogus.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o.stderr).contains("bogus.json"), "{}", text(&o.stderr));
    let o = envpg(&["plot", "--window", "0", &files[0]]);
    assert_eq!(o.status.code(), Some(2));
}

#[test]
fn sweep_writes_a_table_and_a_figure_with_estimator_statistics() {
    let tmp = tempfile::tempdir().unwrap();
    let instance = tiny_instance(tmp.path());
    let out = tmp.path().join("sweep");
    let args = [
        "sweep",
        "--instance",
        &instance,
        "--param",
        "sigma",
        "--values",
        "0.05,0.3",
        "--seeds",
        "1",
        "--preset",
        "smoke",
        "--study-samples",
        "6",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ];
    let stdout = ok(&envpg(&args));
    assert!(stdout.contains("Sweep of `sigma`"), "{stdout}");
    let rows = read_csv(&out.join("sweep.csv"));
    assert_eq!(rows.iter().map(|r| r["value"].as_str()).collect::<Vec<_>>(), ["0.05", "0.3"]);
    for r in &rows {
        for col in [
            "J",
            "variance",
            "rel_bias",
            "variance_sampled",
            "variance_baseline",
            "rel_bias_corollary",
            "critic_error_fixed_states",
            "critic_error_design_states",
            "critic_value_rmse",
        ] {
            let x: f64 = r[col].parse().unwrap_or_else(|_| panic!("{col} of {r:?}"));
            assert!(x.is_finite() && x >= 0.0, "{col} = {x}");
        }
        // The swept value is the run's setting.
        let result: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join(&r["file"])).unwrap()).unwrap();
        assert_eq!(result["config"]["sigma"].as_f64().unwrap().to_string(), r["value"]);
    }
    let md = read_markdown_table(&out.join("sweep.md"));
    assert_eq!(md.len(), 2 + 2);
    check_figure(&out, "sweep");

    // Re-running reads finished runs and their studies back; a run made afresh (its file gone,
    // or its settings changed) gets a fresh study, never the old one.
    let runs = out.join("runs");
    for f in std::fs::read_dir(&runs).unwrap().map(|e| e.unwrap().path()) {
        if f.to_str().unwrap().ends_with(".study.json") {
            let mut study: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&f).unwrap()).unwrap();
            for e in study["estimators"].as_array_mut().unwrap() {
                e["variance"] = 12345.0.into();
            }
            std::fs::write(&f, study.to_string()).unwrap();
        }
    }
    ok(&envpg(&args));
    let variance = |rows: &[BTreeMap<String, String>], v: &str| -> f64 {
        rows.iter().find(|r| r["value"] == v).unwrap()["variance"].parse().unwrap()
    };
    let rows = read_csv(&out.join("sweep.csv"));
    assert_eq!((variance(&rows, "0.05"), variance(&rows, "0.3")), (12345.0, 12345.0), "studies read back");
    std::fs::remove_file(out.join(&rows[0]["file"])).unwrap();
    ok(&envpg(&args));
    let rows = read_csv(&out.join("sweep.csv"));
    assert_ne!(variance(&rows, "0.05"), 12345.0, "the re-made run's study is fresh");
    assert_eq!(variance(&rows, "0.3"), 12345.0, "the other run and its study are kept");

    // Unknown settings and unparsable values are input errors.
    let mut bad = args.to_vec();
    bad[4] = "sigmaa";
    let o = envpg(&bad);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o.stderr).contains("unknown setting"), "{}", text(&o.stderr));
    let mut bad = args.to_vec();
    bad[6] = "0.1,lots";
    assert_eq!(envpg(&bad).status.code(), Some(2));
}
