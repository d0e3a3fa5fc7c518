//! The EnvPG ζ-gradient estimators at a fixed (θ, φ, ζ) on a tiny instance: they point the way
//! of the exact model gradient of J_H for the same policy, and the ζ-baseline changes the
//! variance but not the expectation.

mod support;

use envpg_ac::ZetaEstimator;
use envpg_ac::rollout::run_iteration;
use envpg_ac::study::estimator_study;
use envpg_ac::trainer::advance;
use envpg_core::Streams;

/// Trains with ζ frozen at its random start, where the true gradient is large.
fn frozen_spec() -> envpg_ac::trainer::RunSpec {
    let mut spec = support::tiny_spec(0.9, 3, 400);
    spec.config.zeta_lr = 0.0;
    spec
}

#[test]
fn estimates_point_the_way_of_the_exact_gradient() {
    let study = estimator_study(&frozen_spec(), &support::registry(), 400, 200).unwrap();
    let norm: f64 = study.exact.iter().map(|x| x * x).sum::<f64>().sqrt();
    assert!(norm > 1.0, "the frozen design should be far from stationary (‖∇‖ = {norm})");
    for e in &study.estimators {
        assert!(e.cos_exact > 0.9, "{:?}: cosine with the exact gradient {}", e.estimator, e.cos_exact);
    }
    let var = |k: ZetaEstimator| study.estimators.iter().find(|e| e.estimator == k).unwrap().variance;
    assert!(var(ZetaEstimator::Baseline) < var(ZetaEstimator::Sampled), "the baseline should reduce the variance");

    // The critic audit splits the fixed-policy gradient by state: its exact parts add up to it,
    // and the trained critic's version points the same way.
    let audit = study.critic.as_ref().expect("a soft policy terminates, so the audit exists");
    let (f, g) = (&audit.fixed_states, &audit.design_states);
    for (c, want) in study.exact_fixed_policy.iter().enumerate() {
        let got = f.exact[c] + g.exact[c];
        assert!((got - want).abs() < 1e-9 * (1.0 + want.abs()), "component {c}: {got} vs {want}");
    }
    let critic: Vec<f64> = f.critic.iter().zip(&g.critic).map(|(a, b)| a + b).collect();
    let dot: f64 = critic.iter().zip(&study.exact_fixed_policy).map(|(a, b)| a * b).sum();
    let norm = |x: &[f64]| x.iter().map(|v| v * v).sum::<f64>().sqrt();
    let cos = dot / (norm(&critic) * norm(&study.exact_fixed_policy));
    assert!(cos > 0.9, "the critic's fixed-policy gradient has cosine {cos} with the exact one");
    assert!(audit.value_rmse.is_finite() && audit.value_rmse >= 0.0);
}

#[test]
fn baseline_and_sampled_estimators_agree_in_expectation() {
    let spec = frozen_spec();
    let (env, _, mut learner) = spec.start(&support::registry()).unwrap();
    let net = env.sampler();
    let streams = Streams::new(spec.seed);
    let sets = learner.action_sets().clone();
    advance(net, &mut learner, &spec.config, &streams, 300).unwrap();
    // Paired differences on the same batches: E[∇ζ ln π · V(s)] = 0, so their mean is zero up
    // to its standard error.
    let zeta = learner.zeta().to_vec();
    let d = zeta.len();
    let n = 400;
    let (mut sum, mut sq) = (vec![0.0; d], vec![0.0; d]);
    for i in 0..n {
        let mut table = learner.policy_table();
        let episodes = run_iteration(net, &sets, &mut table, &zeta, &spec.config, &streams, 1_000_000 + i);
        let on: Vec<_> = episodes.iter().filter(|e| !e.explore).collect();
        let a = learner.zeta_gradient_with(&on, ZetaEstimator::Sampled);
        let b = learner.zeta_gradient_with(&on, ZetaEstimator::Baseline);
        for c in 0..d {
            let diff = a[c] - b[c];
            sum[c] += diff;
            sq[c] += diff * diff;
        }
    }
    // A χ²-style check over all coordinates keeps the false-alarm rate low.
    let nf = n as f64;
    let mut chi2 = 0.0;
    for c in 0..d {
        let mean = sum[c] / nf;
        let var = (sq[c] / nf - mean * mean) * nf / (nf - 1.0);
        let se2 = var / nf;
        chi2 += mean * mean / se2.max(1e-30);
    }
    // 99.9% quantile of χ² with 6 degrees of freedom is 22.46.
    assert!(chi2 < 22.46, "paired difference is not centred on zero: χ² = {chi2} over {d} coordinates");
}
