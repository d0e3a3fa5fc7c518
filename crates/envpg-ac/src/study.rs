//! The ζ-gradient estimators side by side at a fixed (θ, φ, ζ): train a learner for a while,
//! freeze it, then draw many independent batches and compare each estimator's mean, spread and
//! direction with the exact gradient of J_H for the same policy (computed from the model, for
//! reporting only).

use envpg_core::{Streams, UavNetwork};
use envpg_model::{Snapshot, SoftSolution, corollary_gradient, evaluate, theorem_gradient};
use serde::{Deserialize, Serialize};

use crate::config::ZetaEstimator;
use crate::exact::ActorPolicy;
use crate::learner::{Batch, Learner};
use crate::rollout::run_iteration;
use crate::trainer::{RunSpec, TrainError};

/// Statistics of one estimator over independent batches.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct EstimatorStats {
    /// Which estimator.
    pub estimator: ZetaEstimator,
    /// Mean estimate.
    pub mean: Vec<f64>,
    /// Per-coordinate standard error of the mean.
    pub std_err: Vec<f64>,
    /// Total variance of one estimate (trace of its covariance).
    pub variance: f64,
    /// Cosine of the mean with the exact gradient of J_H(π_θ(·|·, ζ), ζ) (theorem, all terms).
    pub cos_exact: f64,
    /// Cosine of the mean with the exact gradient for the policy held fixed (Gibbs corollary).
    pub cos_fixed_policy: f64,
    /// Relative bias ‖mean − exact‖/‖exact‖.
    pub rel_bias: f64,
}

/// The result of [`estimator_study`].
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Study {
    /// Iterations trained before freezing.
    pub trained: usize,
    /// Independent batches per estimator.
    pub samples: usize,
    /// Exact ∇ζ J_H of the frozen policy (theorem).
    pub exact: Vec<f64>,
    /// Exact gradient with the policy held fixed.
    pub exact_fixed_policy: Vec<f64>,
    /// Per estimator.
    pub estimators: Vec<EstimatorStats>,
}

fn cos(a: &[f64], b: &[f64]) -> f64 {
    let d: f64 = a.iter().zip(b).map(|(x, y)| x * y).sum();
    let na: f64 = a.iter().map(|x| x * x).sum::<f64>().sqrt();
    let nb: f64 = b.iter().map(|x| x * x).sum::<f64>().sqrt();
    d / (na * nb).max(1e-300)
}

/// Trains `spec` for `train` iterations (its own ζ schedule applies), then estimates the
/// ζ-gradient with every estimator on `samples` independent batches drawn at the frozen
/// (θ, φ, ζ, α).
pub fn estimator_study(spec: &RunSpec, train: usize, samples: usize) -> Result<Study, TrainError> {
    let (net, _, mut learner) = spec.start()?;
    let streams = Streams::new(spec.seed);
    let sets = learner.action_sets().clone();
    for _ in 0..train {
        let k = learner.k();
        let mut table = learner.policy_table();
        let zeta = learner.zeta().to_vec();
        let episodes = run_iteration(&net, &sets, &mut table, &zeta, &spec.config, &streams, k);
        learner.update(&Batch { k, episodes })?;
    }
    let zeta = learner.zeta().to_vec();
    let alpha = learner.alpha();
    let (exact, exact_fixed) = exact_gradients(&net, &learner, &zeta, alpha);
    let kinds = [ZetaEstimator::Sampled, ZetaEstimator::Baseline, ZetaEstimator::Expected, ZetaEstimator::Corollary];
    let d = zeta.len();
    let mut sums = vec![(vec![0.0; d], vec![0.0; d]); kinds.len()];
    // Batches come from streams past the training iterations, so they are fresh and independent.
    for i in 0..samples {
        let k = (train + 1_000_000 + i) as u64;
        let mut table = learner.policy_table();
        let episodes = run_iteration(&net, &sets, &mut table, &zeta, &spec.config, &streams, k);
        let on: Vec<_> = episodes.iter().filter(|e| !e.explore).collect();
        for (j, &kind) in kinds.iter().enumerate() {
            let g = learner.zeta_gradient_with(&on, kind);
            for c in 0..d {
                sums[j].0[c] += g[c];
                sums[j].1[c] += g[c] * g[c];
            }
        }
    }
    let n = samples.max(1) as f64;
    let estimators = kinds
        .iter()
        .zip(sums)
        .map(|(&estimator, (s, sq))| {
            let mean: Vec<f64> = s.iter().map(|x| x / n).collect();
            let var: Vec<f64> =
                sq.iter().zip(&mean).map(|(q, m)| (q / n - m * m).max(0.0) * n / (n - 1.0).max(1.0)).collect();
            let norm_exact = exact.iter().map(|x| x * x).sum::<f64>().sqrt().max(1e-300);
            EstimatorStats {
                estimator,
                std_err: var.iter().map(|v| (v / n).sqrt()).collect(),
                variance: var.iter().sum(),
                cos_exact: cos(&mean, &exact),
                cos_fixed_policy: cos(&mean, &exact_fixed),
                rel_bias: mean.iter().zip(&exact).map(|(a, b)| (a - b).powi(2)).sum::<f64>().sqrt() / norm_exact,
                mean,
            }
        })
        .collect();
    Ok(Study { trained: train, samples, exact, exact_fixed_policy: exact_fixed, estimators })
}

/// Exact ∇ζ J_H of the learner's current policy at `zeta`: all terms of the theorem, and with
/// the policy held fixed.
pub fn exact_gradients(net: &UavNetwork, learner: &Learner, zeta: &[f64], alpha: f64) -> (Vec<f64>, Vec<f64>) {
    let features = learner.features().centered(zeta);
    let pol = ActorPolicy::new(learner.actor(), &features, learner.action_sets());
    let full = theorem_gradient(net, zeta, &pol, alpha).unwrap_or_else(|_| vec![f64::NAN; zeta.len()]);
    let snap = Snapshot::build(net, zeta);
    let mut table = learner.policy_table();
    let pi = table.full().to_vec();
    let fixed = evaluate(&snap, &pi, alpha)
        .and_then(|v| corollary_gradient(net, zeta, &snap, &SoftSolution { alpha, v: v.v, pi, j: v.j }))
        .unwrap_or_else(|_| vec![f64::NAN; zeta.len()]);
    (full, fixed)
}
