//! `envpg-launch --in-process` end to end on a tiny budget, and its input errors.

use std::process::Command;

fn launch(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_envpg-launch"))
        .args(args)
        // Default run directories (runs/<id>) stay out of the source tree.
        .env("ENVPG_RUNS_DIR", std::env::temp_dir().join("envpg-test-runs"))
        .output()
        .expect("envpg-launch runs")
}

#[test]
fn smoke_run_writes_a_result_that_rescoring_confirms() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("r.json");
    let o = launch(&[
        "--in-process",
        "--preset",
        "smoke",
        "--kappa",
        "0.9",
        "--seed",
        "3",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let r = envpg_core::ResultFile::load(&out).unwrap();
    assert_eq!(r.method, "envpg-ac");
    assert_eq!((r.env.as_str(), r.param("kappa"), r.seed), ("uav", Some(0.9), 3));
    assert_eq!(r.history.as_ref().unwrap().len(), 30);
    let cfg = r.config.as_ref().unwrap();
    assert_eq!(cfg["iterations"], 30);
    // The stored J is the exact J of the stored design and policy.
    let env = r.load_env(&envpg_envs::registry(), &out).unwrap();
    let model = env.model().unwrap();
    let snap = envpg_model::Snapshot::build(model, &r.zeta);
    let pi = envpg_core::policy::pairs_from_rows(model, &r.policy).unwrap();
    match (envpg_model::evaluate(&snap, &pi, 0.0), r.j) {
        (Ok(v), Some(j)) => assert!((v.j - j).abs() < 1e-9 * j.max(1.0)),
        (Err(_), None) => assert!(r.j_error.is_some()),
        (a, b) => panic!("stored J {b:?} disagrees with {a:?}"),
    }
}

#[test]
fn every_built_in_environment_trains_and_its_result_rescores() {
    let registry = envpg_envs::registry();
    for (instance, extra) in
        [("aac1800", vec!["--env-param", "temperature=0.01"]), ("flpo-n10m4", vec!["--kappa", "0.9"])]
    {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("r.json");
        let mut args = vec!["--in-process", "--preset", "smoke", "--instance", instance, "--quiet", "--out"];
        args.push(out.to_str().unwrap());
        args.extend(extra);
        let o = launch(&args);
        assert!(o.status.success(), "{instance}: {}", String::from_utf8_lossy(&o.stderr));
        let r = envpg_core::ResultFile::load(&out).unwrap();
        let env = r.load_env(&registry, &out).unwrap();
        assert_eq!(r.env, env.name);
        let model = env.model().unwrap();
        let snap = envpg_model::Snapshot::build(model, &r.zeta);
        let pi = envpg_core::policy::pairs_from_rows(model, &r.policy).unwrap();
        let j = envpg_model::evaluate(&snap, &pi, 0.0).unwrap().j;
        assert!((j - r.j.unwrap()).abs() < 1e-9 * j.max(1.0), "{instance}: {j} vs {:?}", r.j);
        env.sampler().zeta_space().check(&r.zeta).expect("the design respects its bounds");
    }
}

#[test]
fn bad_settings_exit_with_code_2_and_name_the_setting() {
    let cases: &[(&[&str], &str)] = &[
        (&["--in-process", "--kappa", "0"], "kappa"),
        (&["--in-process", "--sigma=-1"], "sigma"),
        (&["--in-process", "--alpha0", "NaN"], "alpha0"),
        (&["--in-process", "--preset", "nope"], "no preset named"),
        (&["--in-process", "--zeta0", "1,2,3"], "zeta0"),
        (&["--in-process", "--no-such-flag"], "unexpected argument"),
        (&["--in-process", "--instance", "aac1800", "--kappa", "0.9"], "has no parameter \"kappa\""),
        (
            &["--in-process", "--instance", "flpo-n10m4", "--zeta0", "2,0.5,0.5,0.5,0.5,0.5,0.5,0.5"],
            "outside its bounds",
        ),
        (&["--in-process", "--instance", "aac1800", "--zeta0", "env"], "no initial design of its own"),
        (&["--in-process", "--instance", "flpo-n10m4", "--zeta0", "clustered"], "no clustered design"),
        (&["--in-process", "--instance", "/no/such/instance.json"], "/no/such/instance.json"),
    ];
    for (args, needle) in cases {
        let o = launch(args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: {err}");
    }
}

#[cfg(not(feature = "multi-host"))]
#[test]
fn multi_host_options_say_how_to_enable_them() {
    for args in
        [&["--listen", "tcp/127.0.0.1:7447", "--preset", "smoke"][..], &["worker", "--connect", "tcp/127.0.0.1:7447"]]
    {
        let o = launch(args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains("--features envpg-launch/multi-host"), "{err}");
    }
}
