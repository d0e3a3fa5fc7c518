//! `envpg-launch --passes N`: each pass after the first trains with a seed of its own from the
//! design of the best pass before it (`--pass-start best`), from a ζ₀ of its own (`fresh`), from
//! the best design moved by noise (`kick`), from there with the best pass's networks over the
//! end of the schedule (`warm`, the default), or half fresh then warm (`portfolio`); the best pass (ranked by sampled cost) is the
//! result and every pass is listed;
//! the same seed gives the same result in every mode, and `--resume` continues a run whose
//! last pass did not finish, ending as the uninterrupted run does.

mod support;

use envpg_core::ParamMdp as _;
use std::path::Path;
use std::time::Duration;

use support::launch::{comparable, run, small_run, tiny_instance_file, with};

fn passes(r: &serde_json::Value) -> &Vec<serde_json::Value> {
    r["details"]["passes"]["runs"].as_array().expect("details.passes.runs")
}

fn load(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

#[test]
fn fresh_passes_start_anew_and_the_best_is_kept() {
    let dir = tempfile::tempdir().unwrap();
    let inst = tiny_instance_file(dir.path());
    let base = with(small_run(&inst, 4, 40), &["--passes", "3", "--pass-start", "fresh"]);
    let out = dir.path().join("three.json");
    let run_dir = dir.path().join("run");
    let o = run(
        &with(
            base.clone(),
            &["--workers", "2", "--run-dir", &run_dir.display().to_string(), "--out", &out.display().to_string()],
        ),
        Duration::from_secs(240),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let r = load(&out);
    let runs = passes(&r);
    assert_eq!(runs.len(), 3);
    let kept = r["details"]["passes"]["kept"].as_u64().unwrap() as usize;
    // The result is the kept pass's: its design, its J, and the lowest sampled cost.
    assert_eq!(r["zeta"], runs[kept - 1]["zeta"]);
    assert_eq!(r["J"], runs[kept - 1]["J"]);
    let estimate = |i: usize| runs[i]["j_estimate"].as_f64().unwrap();
    assert!((0..3).all(|i| estimate(kept - 1) <= estimate(i)), "{runs:?}");
    // Pass 1 has the run's seed, the others seeds of their own, and so starts of their own
    // (random ζ₀ here); the result names the run's seed.
    assert_eq!((r["seed"].as_u64(), runs[0]["seed"].as_u64()), (Some(4), Some(4)));
    let distinct = |key: &str| (0..3).all(|i| (0..i).all(|j| runs[i][key] != runs[j][key]));
    assert!(distinct("seed") && distinct("zeta0"), "{runs:?}");
    assert_eq!(r["details"]["passes"]["start"], "fresh");
    // Each pass is a run of its own, kept in its directory; the run's seconds cover them all.
    for p in 1..=3 {
        let own = load(&run_dir.join(format!("pass-{p}/result.json")));
        assert_eq!(own["zeta"], runs[p - 1]["zeta"]);
        assert!(run_dir.join(format!("pass-{p}/metrics.csv")).exists());
    }
    let seconds: f64 = runs.iter().map(|p| p["seconds"].as_f64().unwrap()).sum();
    assert!(r["seconds"].as_f64().unwrap() >= seconds);

    // Same seed, same result, in one process with one worker.
    let single = dir.path().join("single.json");
    let o = run(
        &with(base.clone(), &["--in-process", "--workers", "1", "--out", &single.display().to_string()]),
        Duration::from_secs(240),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(comparable(&single), comparable(&out));
    assert_eq!(
        passes(&load(&single)).iter().map(|p| &p["zeta"]).collect::<Vec<_>>(),
        runs.iter().map(|p| &p["zeta"]).collect::<Vec<_>>()
    );

    // The last pass lost its result (as if stopped during its polish): --resume reruns it from
    // its final checkpoint and ends with the same result.
    std::fs::remove_file(run_dir.join("pass-3/result.json")).unwrap();
    std::fs::remove_file(&out).unwrap();
    let o = run(&["--resume".into(), run_dir.display().to_string(), "--quiet".into()], Duration::from_secs(240));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(comparable(&out), comparable(&single));
    // A corrupt checkpoint of an unfinished pass is refused before anything runs.
    std::fs::remove_file(run_dir.join("pass-3/result.json")).unwrap();
    std::fs::write(run_dir.join("pass-3/checkpoint.bin"), b"not a checkpoint").unwrap();
    let o = run(&["--resume".into(), run_dir.display().to_string(), "--quiet".into()], Duration::from_secs(60));
    assert_eq!(o.status.code(), Some(2), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stderr).contains("pass-3"), "{}", String::from_utf8_lossy(&o.stderr));
}

#[test]
fn best_passes_start_from_the_best_design_so_far() {
    let dir = tempfile::tempdir().unwrap();
    let inst = tiny_instance_file(dir.path());
    let out = dir.path().join("best.json");
    let run_dir = dir.path().join("run");
    let args = with(
        small_run(&inst, 4, 40),
        &[
            "--passes",
            "3",
            "--pass-start",
            "best",
            "--in-process",
            "--workers",
            "1",
            "--run-dir",
            &run_dir.display().to_string(),
            "--out",
            &out.display().to_string(),
        ],
    );
    let o = run(&args, Duration::from_secs(240));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let r = load(&out);
    let runs = passes(&r);
    assert_eq!(r["details"]["passes"]["start"], "best");
    // Pass 1 is the fresh run's pass 1; pass 2 starts where pass 1 ended, pass 3 where the
    // better of the two (by sampled cost) ended, each with a seed of its own.
    let estimate = |i: usize| runs[i]["j_estimate"].as_f64().unwrap();
    assert_eq!(runs[1]["zeta0"], runs[0]["zeta"]);
    let better = if estimate(1) < estimate(0) { 1 } else { 0 };
    assert_eq!(runs[2]["zeta0"], runs[better]["zeta"]);
    assert!(runs[1]["seed"] != runs[0]["seed"] && runs[2]["seed"] != runs[1]["seed"], "{runs:?}");
    let kept = r["details"]["passes"]["kept"].as_u64().unwrap() as usize;
    assert!((0..3).all(|i| estimate(kept - 1) <= estimate(i)), "{runs:?}");
    assert_eq!(r["zeta"], runs[kept - 1]["zeta"]);

    // Resumed during pass 3, the run ends as it did, counting the same rankings' transitions.
    std::fs::remove_file(run_dir.join("pass-3/result.json")).unwrap();
    std::fs::remove_file(&out).unwrap();
    let o = run(&["--resume".into(), run_dir.display().to_string(), "--quiet".into()], Duration::from_secs(240));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let resumed = load(&out);
    assert_eq!(resumed["zeta"], r["zeta"]);
    assert_eq!(resumed["J"], r["J"]);
    assert_eq!(resumed["details"]["transitions"], r["details"]["transitions"]);
    let without_seconds = |runs: &Vec<serde_json::Value>| {
        runs.iter()
            .map(|p| {
                let mut p = p.clone();
                p["seconds"] = serde_json::Value::Null;
                p
            })
            .collect::<Vec<_>>()
    };
    assert_eq!(without_seconds(passes(&resumed)), without_seconds(runs));
}

#[test]
fn kicked_passes_start_near_the_best_design_so_far() {
    let dir = tempfile::tempdir().unwrap();
    let inst = tiny_instance_file(dir.path());
    let out = dir.path().join("kick.json");
    let args = with(
        small_run(&inst, 4, 40),
        &[
            "--passes",
            "3",
            "--pass-start",
            "kick",
            "--in-process",
            "--workers",
            "1",
            "--out",
            &out.display().to_string(),
        ],
    );
    let o = run(&args, Duration::from_secs(240));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let r = load(&out);
    let runs = passes(&r);
    assert_eq!(r["details"]["passes"]["start"], "kick");
    // Pass 2 starts from pass 1's design, pass 3 from the better of the two (by sampled cost),
    // each moved by noise of 2% and 4% of the design space's scale.
    let scale =
        envpg_envs::uav::UavNetwork::new(support::tiny_instance(20, 3, 5), 0.9, 1.0).unwrap().zeta_space().scale()[0];
    let vec = |v: &serde_json::Value| -> Vec<f64> { serde_json::from_value(v.clone()).unwrap() };
    let estimate = |i: usize| runs[i]["j_estimate"].as_f64().unwrap();
    let better = if estimate(1) < estimate(0) { 1 } else { 0 };
    for (p, from, relative) in [(1, 0, 0.02), (2, better, 0.04)] {
        let (start, best) = (vec(&runs[p]["zeta0"]), vec(&runs[from]["zeta"]));
        let moved: Vec<f64> = start.iter().zip(&best).map(|(a, b)| (a - b) / (relative * scale)).collect();
        // Six coordinates of N(0, 1) noise: none zero, none beyond 6.
        assert!(moved.iter().all(|m| *m != 0.0 && m.abs() < 6.0), "pass {}: {moved:?}", p + 1);
    }
    assert!(runs[1]["seed"] != runs[0]["seed"] && runs[2]["seed"] != runs[1]["seed"], "{runs:?}");
    let kept = r["details"]["passes"]["kept"].as_u64().unwrap() as usize;
    assert!((0..3).all(|i| estimate(kept - 1) <= estimate(i)), "{runs:?}");
}

#[test]
fn warm_passes_train_on_from_the_best_pass_over_the_last_quarter_and_resume_alike() {
    let dir = tempfile::tempdir().unwrap();
    let inst = tiny_instance_file(dir.path());
    let out = dir.path().join("warm.json");
    let run_dir = dir.path().join("run");
    let mut base = with(small_run(&inst, 4, 40), &["--passes", "3"]);
    let every = base.iter().position(|a| a == "--eval-every").unwrap() + 1;
    base[every] = "10".into();
    let o = run(
        &with(
            base.clone(),
            &[
                "--pass-start",
                "warm",
                "--workers",
                "2",
                "--run-dir",
                &run_dir.display().to_string(),
                "--out",
                &out.display().to_string(),
            ],
        ),
        Duration::from_secs(240),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let r = load(&out);
    let runs = passes(&r);
    assert_eq!(r["details"]["passes"]["start"], "warm");
    let estimate = |i: usize| runs[i]["j_estimate"].as_f64().unwrap();
    let better = if estimate(1) < estimate(0) { 1 } else { 0 };
    // Pass 1 trains all 40 iterations; passes 2 and 3 the last 10 (from k = 30), each from the
    // best design so far moved by a kick, at the schedule's α of iteration 30.
    let history = |p: usize| load(&run_dir.join(format!("pass-{p}/result.json")))["history"].clone();
    let ks = |p: usize| history(p).as_array().unwrap().iter().map(|h| h["k"].as_u64().unwrap()).collect::<Vec<_>>();
    assert_eq!(ks(1), (0..40).collect::<Vec<_>>());
    for p in [2, 3] {
        assert_eq!(ks(p), (30..40).collect::<Vec<_>>(), "pass {p}");
        let first = &history(p)[0];
        // The nominal schedule's α_30 (α_final = α₀/100 over 40 iterations), from α₀ as pass 1
        // began.
        let alpha0 = history(1)[0]["alpha"].as_f64().unwrap();
        let nominal = alpha0 * 0.01f64.powf(30.0 / 39.0);
        assert!((first["alpha"].as_f64().unwrap() / nominal - 1.0).abs() < 1e-12, "pass {p}: {first}");
        assert_eq!(first["zeta"], runs[p - 1]["zeta0"], "pass {p} starts at its kicked design");
        let transitions = |i: usize| runs[i]["transitions"].as_u64().unwrap();
        assert!(transitions(p - 1) < transitions(0), "a warm pass costs less than pass 1: {runs:?}");
    }
    for (p, from) in [(1, 0), (2, better)] {
        assert_ne!(runs[p]["zeta0"], runs[from]["zeta"], "pass {} is kicked", p + 1);
    }
    // The networks carry over: at its first iteration a warm pass's greedy policy is pass 1's
    // late one (exact J, scored for the record every 10 iterations), not a new network's.
    let exact = |p: usize, k: u64| {
        let h = history(p);
        let row = h.as_array().unwrap().iter().find(|h| h["k"] == k).cloned().unwrap();
        row["J_exact"].as_f64().unwrap()
    };
    let (new, late) = (exact(1, 0), exact(1, 30));
    for p in [2, 3] {
        let warm = exact(p, 30);
        assert!(warm < 2.0 * late && warm < new / 4.0, "pass {p} starts at J {warm}; pass 1 went {new} → {late}");
    }
    let kept = r["details"]["passes"]["kept"].as_u64().unwrap() as usize;
    assert!((0..3).all(|i| estimate(kept - 1) <= estimate(i)), "{runs:?}");

    // Same seed, same result, in one process with one worker; `warm` is the default.
    let single = dir.path().join("single.json");
    let o = run(
        &with(base, &["--in-process", "--workers", "1", "--out", &single.display().to_string()]),
        Duration::from_secs(240),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(comparable(&single), comparable(&out));
    assert_eq!(load(&single)["details"]["passes"]["start"], "warm");

    // Stopped after pass 3's run description was written and before its warm start was: the
    // resumed run writes the warm start again and ends as the uninterrupted run did.
    std::fs::remove_file(run_dir.join("pass-3/result.json")).unwrap();
    std::fs::remove_file(run_dir.join("pass-3/checkpoint.bin")).unwrap();
    std::fs::remove_file(&out).unwrap();
    let o = run(&["--resume".into(), run_dir.display().to_string(), "--quiet".into()], Duration::from_secs(240));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(comparable(&out), comparable(&single));
    // Without the best pass's final checkpoint there is nothing to start from: refused, exit 2,
    // naming it.
    std::fs::remove_file(run_dir.join("pass-3/result.json")).unwrap();
    std::fs::remove_file(run_dir.join("pass-3/checkpoint.bin")).unwrap();
    std::fs::remove_file(run_dir.join(format!("pass-{}/checkpoint.bin", better + 1))).unwrap();
    let o = run(&["--resume".into(), run_dir.display().to_string(), "--quiet".into()], Duration::from_secs(60));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("--pass-start warm") && stderr.contains("final checkpoint"), "{stderr}");
}

#[test]
fn a_portfolio_runs_its_first_half_as_fresh_passes_then_warm_ones_from_the_best_of_them() {
    let dir = tempfile::tempdir().unwrap();
    let inst = tiny_instance_file(dir.path());
    let (out, fresh) = (dir.path().join("portfolio.json"), dir.path().join("fresh.json"));
    let run_dir = dir.path().join("run");
    let base = with(small_run(&inst, 4, 40), &["--in-process", "--workers", "1"]);
    let o = run(
        &with(
            base.clone(),
            &[
                "--passes",
                "4",
                "--pass-start",
                "portfolio",
                "--run-dir",
                &run_dir.display().to_string(),
                "--out",
                &out.display().to_string(),
            ],
        ),
        Duration::from_secs(240),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = run(
        &with(base, &["--passes", "2", "--pass-start", "fresh", "--out", &fresh.display().to_string()]),
        Duration::from_secs(240),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let r = load(&out);
    let runs = passes(&r);
    assert_eq!(r["details"]["passes"]["start"], "portfolio");
    // Passes 1 and 2 (the first half) are the two fresh passes of a `fresh` run, bit for bit,
    // sampled cost in the ranking included (each design is sampled on the same episodes
    // whatever else is ranked with it).
    let without_seconds = |p: &serde_json::Value| {
        let mut p = p.clone();
        p["seconds"] = serde_json::Value::Null;
        p
    };
    let fresh = load(&fresh);
    for i in 0..2 {
        assert_eq!(without_seconds(&runs[i]), without_seconds(&passes(&fresh)[i]), "pass {}", i + 1);
    }
    // Passes 3 and 4 are warm: the last quarter of the schedule, from the best pass so far
    // (by sampled cost in the ranking before each) kicked by 2% and then 4% of the scale.
    let ks = |p: usize| {
        let h = load(&run_dir.join(format!("pass-{p}/result.json")))["history"].clone();
        h.as_array().unwrap().iter().map(|h| h["k"].as_u64().unwrap()).collect::<Vec<_>>()
    };
    assert_eq!(ks(2), (0..40).collect::<Vec<_>>());
    assert_eq!(ks(3), (30..40).collect::<Vec<_>>());
    assert_eq!(ks(4), (30..40).collect::<Vec<_>>());
    let scale =
        envpg_envs::uav::UavNetwork::new(support::tiny_instance(20, 3, 5), 0.9, 1.0).unwrap().zeta_space().scale()[0];
    let vec = |v: &serde_json::Value| -> Vec<f64> { serde_json::from_value(v.clone()).unwrap() };
    let kicked_from = |p: usize, relative: f64| {
        let start = vec(&runs[p - 1]["zeta0"]);
        (0..p - 1).find(|&i| {
            let moved = start.iter().zip(vec(&runs[i]["zeta"])).map(|(a, b)| (a - b) / (relative * scale));
            moved.clone().all(|m| m != 0.0 && m.abs() < 6.0)
        })
    };
    assert!(kicked_from(3, 0.02).is_some(), "pass 3 starts near pass 1's or 2's design: {runs:?}");
    assert!(kicked_from(4, 0.04).is_some(), "pass 4 starts near an earlier pass's design: {runs:?}");
    let kept = r["details"]["passes"]["kept"].as_u64().unwrap() as usize;
    let estimate = |i: usize| runs[i]["j_estimate"].as_f64().unwrap();
    assert!((0..4).all(|i| estimate(kept - 1) <= estimate(i)), "{runs:?}");
    // The run's transitions are its passes' and one scoring of each pass in the rankings
    // (before passes 3 and 4 and at the end), however many rankings it took part in.
    let sum = |key: &str| runs.iter().map(|p| p[key].as_u64().unwrap()).sum::<u64>();
    assert!(runs.iter().all(|p| p["ranking_transitions"].as_u64().unwrap() > 0), "{runs:?}");
    assert_eq!(r["details"]["transitions"].as_u64().unwrap(), sum("transitions") + sum("ranking_transitions"));
}

#[test]
fn zero_passes_passes_with_bench_and_a_pass_start_without_passes_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let inst = tiny_instance_file(dir.path());
    let out = dir.path().join("r.json").display().to_string();
    let o = run(&with(small_run(&inst, 1, 5), &["--passes", "0", "--out", &out]), Duration::from_secs(60));
    assert_eq!(o.status.code(), Some(2), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--passes"));
    let o = run(&with(small_run(&inst, 1, 5), &["--passes", "2", "--bench"]), Duration::from_secs(60));
    assert_eq!(o.status.code(), Some(2), "{}", String::from_utf8_lossy(&o.stderr));
    // --pass-start says where later passes start: with one pass it would be silently ignored.
    let o = run(&with(small_run(&inst, 1, 5), &["--pass-start", "best", "--out", &out]), Duration::from_secs(60));
    assert_eq!(o.status.code(), Some(2), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--pass-start"));
    assert!(!Path::new(&out).exists());
}
