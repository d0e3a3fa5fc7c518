//! The example environment passes envpg's environment checks (derivatives, fast paths, sampler
//! frequencies, the EnvPG theorem against finite differences), and Algorithm 1, model-free,
//! ends at a local optimum of the design within 3% of the oracle's best.

use envpg_ac::AcConfig;
use envpg_ac::trainer::{RunSpec, train};
use envpg_core::checks;
use envpg_model::oracle::{OracleConfig, Strategy, run_oracle};
use envpg_model::random::RandomPolicy;
use envpg_model::{Snapshot, evaluate, fd_gradient, optimal_greedy, policy_table, theorem_gradient};

#[test]
fn the_queues_pass_the_environment_checks_and_the_theorem() {
    let env = envpg_example_queues::registry().load("queues", &[]).unwrap();
    let model = env.model().unwrap();
    let zeta = [0.55, 0.3];
    checks::outcome_derivatives(model, &zeta, 1e-6, 1e-7);
    checks::state_paths(model, &zeta);
    // From empty queues, and from full ones where only rejection is possible.
    let full = env.sampler().n_states() - 1;
    checks::sampler_frequencies(model, 0, 0, &zeta, 100_000);
    checks::sampler_frequencies(model, 7, 1, &zeta, 100_000);
    checks::sampler_frequencies(model, full, 2, &zeta, 100_000);
    // The theorem's right-hand side for a ζ-dependent policy, against central differences of J.
    let policy = RandomPolicy::new(3, model);
    for alpha in [0.0, 0.2] {
        let exact = theorem_gradient(model, &zeta, &policy, alpha).unwrap();
        let j = |z: &[f64]| {
            let snap = Snapshot::build(model, z);
            Ok::<_, ()>(evaluate(&snap, &policy_table(&snap, &policy, z), alpha).unwrap().j)
        };
        let fd = fd_gradient(&zeta, 1e-5, j).unwrap();
        for (e, f) in exact.iter().zip(&fd) {
            assert!((e - f).abs() <= 1e-6 * (1.0 + f.abs()), "theorem {e} vs finite differences {f}");
        }
    }
}

/// The bundled instance has local optima: besides the oracle's best (45.10) one at about
/// (0.55, 0.35) with J ≈ 46.13, 2.3% above; which one a run ends in depends on its ζ₀. So the
/// test asks what holds on every seed: the run improves on its start, ends where descent from
/// its design with the exact model finds nothing more than 0.3% better (a local optimum, the
/// model used for scoring only), and that optimum is within 3% of the best.
#[test]
fn algorithm1_ends_at_a_local_optimum_within_three_percent_of_the_oracle() {
    let registry = envpg_example_queues::registry();
    let env = registry.load("queues", &[]).unwrap();
    let model = env.model().unwrap();
    let base = OracleConfig::for_env(model);
    let oracle = run_oracle(model, &OracleConfig { restarts: 4, ..base.clone() }).unwrap();
    let best = oracle.restarts[oracle.best].j;
    // The crate's own preset (`presets.toml`), its full budget.
    let config = AcConfig::for_env(&registry, None, None, "queues").unwrap();
    let r = train(&RunSpec::new(&env, 1, config), &registry, |_| true).unwrap();
    let j = r.j.expect("a discounted problem always has a value");
    let (_, _, j_start) = optimal_greedy(model, &r.zeta0).unwrap();
    assert!(j < j_start, "the design improved on its start ({j_start} → {j})");
    // Exact descent from the run's design, cold: it stays in that design's basin.
    let local = run_oracle(
        model,
        &OracleConfig {
            restarts: 1,
            strategy: Strategy::Warm,
            init: Some(r.zeta.clone()),
            warm_alpha0: base.alpha_min,
            ..base
        },
    )
    .unwrap();
    let j_local = local.restarts[0].j;
    assert!(j <= 1.003 * j_local, "Algorithm 1: J = {j}, but descent from its design reaches {j_local}");
    assert!(j <= 1.03 * best, "Algorithm 1: J = {j}, oracle {best}");
}
