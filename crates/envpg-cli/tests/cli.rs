//! The `envpg` binary end to end: instance generation, an oracle run whose result file
//! re-scores to the same J, and clear errors with exit code 2 on bad input.

use std::path::Path;
use std::process::{Command, Output};

fn envpg(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_envpg")).args(args).output().expect("envpg runs")
}

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn generate(dir: &Path, users: usize, uavs: usize) -> String {
    let path = dir.join("tiny.json");
    let o = envpg(&[
        "instance",
        "generate",
        "--users",
        &users.to_string(),
        "--uavs",
        &uavs.to_string(),
        "--clusters",
        "3",
        "--seed",
        "4",
        "--out",
        path.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    path.to_str().unwrap().to_owned()
}

#[test]
fn oracle_result_rescored_by_evaluate_matches() {
    let dir = tempfile::tempdir().unwrap();
    let inst = generate(dir.path(), 30, 3);
    let out = dir.path().join("r.json");
    let o =
        envpg(&["oracle", "--instance", &inst, "--kappa", "0.9", "--restarts", "2", "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("best J ="), "{}", stdout(&o));
    let r: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!(r["schema"], "envpg.result.v2");
    assert_eq!((r["env"].as_str(), r["instance"]["params"]["kappa"].as_f64()), (Some("uav"), Some(0.9)));
    assert_eq!(r["method"], "oracle");
    assert_eq!(r["zeta"].as_array().unwrap().len(), 6);
    assert_eq!(r["policy"].as_array().unwrap().len(), 33);
    let e = envpg(&["evaluate", out.to_str().unwrap()]);
    assert!(e.status.success(), "{}{}", stdout(&e), stderr(&e));
    assert!(stdout(&e).contains(" ok"), "{}", stdout(&e));
}

/// `--progress-lines` writes one line on stderr per restart and kick as it ends, each with the
/// run's total, and the last with the best J the run reports; piped, the bar writes nothing.
#[test]
fn progress_lines_count_every_restart_and_kick_and_end_at_the_best_j() {
    let dir = tempfile::tempdir().unwrap();
    let inst = generate(dir.path(), 30, 3);
    let o = envpg(&["oracle", "--instance", &inst, "--restarts", "2", "--progress-lines"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let (out, err) = (stdout(&o), stderr(&o));
    let runs = out.lines().filter(|l| l.trim_start().starts_with("restart ")).count();
    let lines: Vec<&str> = err.lines().collect();
    assert!(runs > 2, "κ = 1: the kicks follow the restarts\n{out}");
    assert!(err.contains(" (kick from ") && err.contains(" (relocation from "), "then the relocations\n{err}");
    assert_eq!(lines.len(), runs, "{err}");
    for (i, l) in lines.iter().enumerate() {
        assert!(l.starts_with(&format!("envpg oracle: {}/{runs} ended, restart ", i + 1)), "{l}");
    }
    let best = out.lines().find_map(|l| l.strip_prefix("best J = ")).unwrap().split(' ').next().unwrap();
    assert!(lines[runs - 1].contains(&format!("best J = {best},")), "{err}\n{out}");
    let quiet = envpg(&["oracle", "--instance", &inst, "--restarts", "2"]);
    assert!(quiet.status.success() && quiet.stderr.is_empty(), "{}", stderr(&quiet));
}

#[test]
fn evaluate_detects_a_tampered_j() {
    let dir = tempfile::tempdir().unwrap();
    let inst = generate(dir.path(), 20, 2);
    let out = dir.path().join("r.json");
    let o = envpg(&["oracle", "--instance", &inst, "--restarts", "1", "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let mut r: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    r["J"] = serde_json::json!(r["J"].as_f64().unwrap() * 0.99);
    std::fs::write(&out, serde_json::to_string(&r).unwrap()).unwrap();
    let e = envpg(&["evaluate", out.to_str().unwrap()]);
    assert_eq!(e.status.code(), Some(1));
    assert!(stdout(&e).contains("MISMATCH"), "{}", stdout(&e));
}

#[test]
fn bad_input_is_refused_with_exit_code_2() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.json");
    std::fs::write(&bad, r#"{"name":"x","n_uav":2,"users":[[0,0]],"dest":[1,1],"dest":[2,2]}"#).unwrap();
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["oracle", "--kappa", "1.5"], "kappa must be in (0, 1]"),
        (vec!["oracle", "--kappa", "NaN"], "kappa"),
        (vec!["oracle", "--instance", bad.to_str().unwrap()], "duplicate field `dest`"),
        (vec!["oracle", "--init", "1,2"], "ζ has 2 entries"),
        (vec!["oracle", "--cooling", "1.2"], "cooling"),
        (vec!["oracle", "--kick-scale", "0"], "kick_scale must be finite and > 0"),
        (vec!["oracle", "--relocation-alpha0", "0"], "--relocation-alpha0 must be finite and > 0"),
        (vec!["oracle", "--tracking-tol=-1"], "tracking_tol must be finite and >= 0"),
        (vec!["oracle", "--threads", "0"], "threads must be at least 1"),
        (vec!["oracle", "--no-such-option"], "unexpected argument"),
        (vec!["evaluate", "/nonexistent/r.json"], "cannot read result file"),
    ];
    for (args, needle) in cases {
        let o = envpg(&args);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(needle), "{args:?}: {}", stderr(&o));
    }
}

#[test]
fn instance_check_summarises_the_bundled_instance() {
    let o = envpg(&["instance", "check", "uav271"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("environment `uav`") && stdout(&o).contains("277 states"), "{}", stdout(&o));
    for (name, env) in [("aac1800", "aac"), ("flpo-n10m4", "flpo")] {
        let o = envpg(&["instance", "check", name]);
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(stdout(&o).contains(&format!("environment `{env}`")), "{}", stdout(&o));
    }
}

#[test]
fn bad_environment_input_exits_2_naming_the_culprit_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, text: &str| {
        let p = dir.path().join(name);
        std::fs::write(&p, text).unwrap();
        p.to_str().unwrap().to_owned()
    };
    let unknown = write("unknown.json", r#"{"env": "nope", "name": "x"}"#);
    let bad_param = write(
        "bad-param.json",
        r#"{"env": "flpo", "name": "f", "facilities": 2, "agents": [{"start": [0.1, 0.1], "dest": 0}],
            "destinations": [[0.9, 0.9]], "params": {"kappa": "high"}}"#,
    );
    let no_points = write("no-points.json", r#"{"env": "aac", "name": "a", "clusters": 2}"#);
    // A result on another environment's instance, given where this one's ζ₀ is expected.
    let flpo = dir.path().join("flpo.json");
    let o = envpg(&["oracle", "--instance", "flpo-n10m4", "--restarts", "1", "--out", flpo.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = dir.path().join("never.json");
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["oracle", "--instance", &unknown], "environment \"nope\", which is not registered"),
        (vec!["oracle", "--instance", &bad_param], "field `params.kappa`"),
        (vec!["oracle", "--instance", &no_points], "field `points`: is missing"),
        (vec!["oracle", "--instance", "aac1800", "--env-param", "kappa=0.9"], "has no parameter \"kappa\""),
        (vec!["oracle", "--instance", "aac1800", "--kappa", "0.9"], "has no parameter \"kappa\""),
        (vec!["oracle", "--instance", "aac1800", "--env-param", "deviation"], "expected KEY=VALUE"),
        (vec!["oracle", "--instance", "aac1800", "--env-param", "deviation=1.5"], "field `params.deviation`"),
        (vec!["oracle", "--instance", "uav271", "--init", flpo.to_str().unwrap()], "flpo-n10m4"),
        (vec!["oracle", "--instance", "flpo-n10m4", "--init", "2,0.5,0.5,0.5,0.5,0.5,0.5,0.5"], "outside its bounds"),
        (vec!["evaluate", "--instance", "flpo-n10m4", "--zeta", "0.5,0.5"], "ζ has 2 entries"),
        (vec!["evaluate", flpo.to_str().unwrap(), "--instance", "aac1800"], "scored on the instance it carries"),
        (vec!["table", "--instance", "aac1800", "--vary", "kappa=1,0.9"], "has no parameter \"kappa\""),
    ];
    for (mut args, needle) in cases {
        if args[0] != "evaluate" && args[0] != "table" {
            args.extend(["--out", out.to_str().unwrap()]);
        }
        let o = envpg(&args);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(needle), "{args:?}: {}", stderr(&o));
        assert!(!stderr(&o).contains("panicked"), "{args:?}: {}", stderr(&o));
        assert!(!out.exists(), "{args:?} wrote its output");
    }
}

#[test]
fn version_1_result_files_still_load_and_rescore() {
    let dir = tempfile::tempdir().unwrap();
    let inst = generate(dir.path(), 20, 2);
    let out = dir.path().join("r.json");
    let o =
        envpg(&["oracle", "--instance", &inst, "--kappa", "0.9", "--restarts", "1", "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    // The same result as the v1 schema wrote it: κ and η beside a bare UAV instance.
    let mut r: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    let obj = r.as_object_mut().unwrap();
    obj.insert("schema".into(), "envpg.result.v1".into());
    obj.remove("env");
    let params = obj["instance"].as_object_mut().unwrap().remove("params").unwrap();
    obj["instance"].as_object_mut().unwrap().remove("env");
    obj.insert("kappa".into(), params["kappa"].clone());
    obj.insert("eta".into(), params["eta"].clone());
    let v1 = dir.path().join("v1.json");
    std::fs::write(&v1, serde_json::to_string(&r).unwrap()).unwrap();
    let e = envpg(&["evaluate", v1.to_str().unwrap()]);
    assert!(e.status.success(), "{}{}", stdout(&e), stderr(&e));
    assert!(
        stdout(&e).contains("env=uav") && stdout(&e).contains("kappa = 0.9") && stdout(&e).contains(" ok"),
        "{}",
        stdout(&e)
    );
}

#[test]
fn envs_lists_every_environment_with_its_parameters() {
    let o = envpg(&["envs"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    for needle in ["uav:", "aac:", "flpo:", "deviation", "temperature", "kappa", "aac1800", "flpo-n10m4", "uav271"] {
        assert!(text.contains(needle), "{needle}: {text}");
    }
}

#[test]
fn bench_plot_draws_a_reports_model_and_refuses_what_is_not_a_report() {
    let dir = tempfile::tempdir().unwrap();
    let report = dir.path().join("bench.json");
    let predictions: Vec<serde_json::Value> = [(1, 2, 12e3, Some(12e3)), (2, 2, 16e3, Some(15e3)), (2, 3, 18e3, None)]
        .iter()
        .flat_map(|&(workers, cores, per_second, measured)| {
            [0, 1].map(|lag| serde_json::json!({ "workers": workers, "lag": lag, "cores": cores, "per_second": per_second, "measured": measured }))
        })
        .collect();
    let json = serde_json::json!({ "emulator_cost_us": 50, "predictions": predictions });
    std::fs::write(&report, json.to_string()).unwrap();
    let out = dir.path().join("figs");
    let o = envpg(&["bench", "plot", report.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    for ext in ["svg", "png"] {
        assert!(out.join(format!("throughput-model.{ext}")).is_file(), "{}", stdout(&o));
    }
    let svg = std::fs::read_to_string(out.join("throughput-model.svg")).unwrap();
    assert!(svg.contains("+50 µs a step, lag 1"), "the legend names each curve");

    // A result file, and a report without the model, are input errors naming the file.
    let not_a_report = dir.path().join("other.json");
    std::fs::write(&not_a_report, r#"{"emulator_cost_us": 0, "predictions": []}"#).unwrap();
    for bad in [not_a_report.to_str().unwrap(), "no/such/report.json"] {
        let o = envpg(&["bench", "plot", bad, "--out", out.to_str().unwrap()]);
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        assert!(stderr(&o).contains(bad), "{}", stderr(&o));
    }
}
