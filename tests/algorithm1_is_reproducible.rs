//! Same seed ⇒ bitwise-identical ζ, policy, J and history (timings aside); another seed ⇒ a
//! different run.

mod support;

use envpg_ac::trainer::train;

fn strip_timings(mut r: envpg_core::ResultFile) -> serde_json::Value {
    r.seconds = None;
    let mut v = serde_json::to_value(&r).unwrap();
    v["details"]["transitions_per_s"] = serde_json::Value::Null;
    v["details"]["polish"]["seconds"] = serde_json::Value::Null;
    v
}

#[test]
fn same_seed_gives_identical_results_and_another_seed_does_not() {
    for kappa in [1.0, 0.85] {
        let spec = support::tiny_spec(kappa, 7, 120);
        let reg = support::registry();
        let a = train(&spec, &reg, |_| true).unwrap();
        let b = train(&spec, &reg, |_| true).unwrap();
        assert_eq!(a.zeta, b.zeta, "kappa {kappa}");
        assert_eq!(strip_timings(a.clone()), strip_timings(b));
        let c = train(&support::tiny_spec(kappa, 8, 120), &reg, |_| true).unwrap();
        assert_ne!(a.zeta, c.zeta);
    }
}
