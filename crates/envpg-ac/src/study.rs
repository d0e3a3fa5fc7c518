//! The ζ-gradient estimators side by side at a fixed (θ, φ, ζ): train a learner for a while,
//! freeze it, then draw many independent batches and compare each estimator's mean, spread and
//! direction with the exact gradient of J_H for the same policy (computed from the model, for
//! reporting only).

use envpg_core::{ModelMdp, Registry, Streams};
use envpg_model::{
    Snapshot, SoftSolution, accumulate_local, corollary_gradient, evaluate, mu_dense, theorem_gradient, visits,
};
use serde::{Deserialize, Serialize};

use crate::config::ZetaEstimator;
use crate::exact::ActorPolicy;
use crate::learner::Learner;
use crate::rollout::run_iteration;
use crate::trainer::{RunSpec, TrainError, advance};

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
    /// The critic's part of the estimators' error, free of sampling noise.
    #[serde(default)]
    pub critic: Option<CriticAudit>,
}

/// The critic audited against the model at the frozen point: for a group of state–action
/// pairs, `Σ ρ(s)π(a|s) ∇ζ Q(s, a, ζ)` with the exact visits ρ of the frozen policy, once with
/// the exact Q̄ (V frozen: the fixed-policy gradient of the theorem) and once with the critic's
/// Q_φ. Their difference is what the critic alone contributes to the estimators' bias.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct AuditPart {
    /// With the exact Q̄.
    pub exact: Vec<f64>,
    /// With the critic Q_φ.
    pub critic: Vec<f64>,
    /// ‖critic − exact‖/‖exact‖.
    pub rel_error: f64,
}

/// [`AuditPart`]s by where the pair's state sits, and the critic's value error.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CriticAudit {
    /// Pairs at states that are not at a design element (in the UAV network, the users).
    pub fixed_states: AuditPart,
    /// Pairs at states at a design element (in the UAV network, the UAVs).
    pub design_states: AuditPart,
    /// Visit-weighted RMS error of Q_φ(s, a, ζ) against the exact soft Q of the frozen policy.
    pub value_rmse: f64,
}

fn cos(a: &[f64], b: &[f64]) -> f64 {
    let d: f64 = a.iter().zip(b).map(|(x, y)| x * y).sum();
    let na: f64 = a.iter().map(|x| x * x).sum::<f64>().sqrt();
    let nb: f64 = b.iter().map(|x| x * x).sum::<f64>().sqrt();
    d / (na * nb).max(1e-300)
}

/// Trains `spec` for `train` iterations (its own ζ schedule applies), then estimates the
/// ζ-gradient with every estimator on `samples` independent batches drawn at the frozen
/// (θ, φ, ζ, α). Needs the environment's model (for the exact gradients it reports against).
pub fn estimator_study(spec: &RunSpec, registry: &Registry, train: usize, samples: usize) -> Result<Study, TrainError> {
    let (env, _, mut learner) = spec.start(registry)?;
    let model = env.model()?;
    let net = env.sampler();
    let streams = Streams::new(spec.seed);
    let sets = learner.action_sets().clone();
    let config = learner.config().clone();
    advance(net, &mut learner, &config, &streams, train)?;
    let zeta = learner.zeta().to_vec();
    let alpha = learner.alpha();
    let (exact, exact_fixed) = exact_gradients(model, &learner, &zeta, alpha);
    let kinds = [ZetaEstimator::Sampled, ZetaEstimator::Baseline, ZetaEstimator::Expected, ZetaEstimator::Corollary];
    let d = zeta.len();
    let mut sums = vec![(vec![0.0; d], vec![0.0; d]); kinds.len()];
    // Batches come from streams past the training iterations, so they are fresh and independent.
    for i in 0..samples {
        let k = (train + 1_000_000 + i) as u64;
        let mut table = learner.policy_table();
        let episodes = run_iteration(net, &sets, &mut table, &zeta, &config, &streams, k);
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
    let critic = critic_audit(model, &mut learner, &zeta, alpha);
    Ok(Study { trained: train, samples, exact, exact_fixed_policy: exact_fixed, estimators, critic })
}

/// The [`CriticAudit`] of `learner` at its design `zeta` (`None` if the frozen policy does not
/// terminate, so that visits are undefined).
pub fn critic_audit<M: ModelMdp + ?Sized>(
    net: &M,
    learner: &mut Learner,
    zeta: &[f64],
    alpha: f64,
) -> Option<CriticAudit> {
    let snap = Snapshot::build(net, zeta);
    let mut at_element = vec![false; net.n_states()];
    for e in net.design_elements() {
        for s in e.states {
            at_element[s] = true;
        }
    }
    let pi = learner.policy_table().full().to_vec();
    let v = evaluate(&snap, &pi, alpha).ok()?;
    let rho = visits(&snap, &pi, &mu_dense(&snap)).ok()?;
    let states = snap.pair_states();
    let weight = |sa: usize| rho[states[sa]] * pi[sa];
    let q_exact = |sa: usize| -> f64 {
        let soft = if pi[sa] > 0.0 { alpha * pi[sa].ln() } else { 0.0 };
        snap.outs(sa).map(|o| snap.prob[o] * (snap.cost[o] + snap.gamma * v.v[snap.next[o]])).sum::<f64>() + soft
    };
    let part = |learner: &mut Learner, design: bool| {
        let w: Vec<f64> =
            (0..snap.n_pairs()).map(|sa| if at_element[states[sa]] == design { weight(sa) } else { 0.0 }).collect();
        let mut u = vec![0.0; snap.next.len()];
        for sa in 0..snap.n_pairs() {
            for o in snap.outs(sa) {
                u[o] = w[sa] * v.v[snap.next[o]];
            }
        }
        let mut exact = vec![0.0; zeta.len()];
        accumulate_local(net, zeta, &snap, &w, &u, &mut exact);
        let pairs: Vec<(usize, usize, f64)> =
            (0..snap.n_pairs()).filter(|&sa| w[sa] > 0.0).map(|sa| (states[sa], snap.sa_action[sa], w[sa])).collect();
        let critic = learner.critic_zeta_gradient(&pairs);
        let norm = |x: &[f64]| x.iter().map(|v| v * v).sum::<f64>().sqrt();
        let diff: Vec<f64> = critic.iter().zip(&exact).map(|(a, b)| a - b).collect();
        AuditPart { rel_error: norm(&diff) / norm(&exact).max(1e-300), exact, critic }
    };
    let fixed_states = part(learner, false);
    let design_states = part(learner, true);
    let (mut sq, mut total) = (0.0, 0.0);
    for s in 0..snap.n_states {
        let pairs = snap.sas(s);
        if pairs.is_empty() || rho[s] == 0.0 {
            continue;
        }
        let q = learner.q_values(s, zeta);
        let acts = learner.action_sets().of(s).to_vec();
        for sa in pairs {
            let Some(i) = acts.iter().position(|&a| a == snap.sa_action[sa]) else { continue };
            sq += weight(sa) * (q[i] - q_exact(sa)).powi(2);
            total += weight(sa);
        }
    }
    let value_rmse = (sq / total.max(1e-300)).sqrt();
    Some(CriticAudit { fixed_states, design_states, value_rmse })
}

/// Exact ∇ζ J_H of the learner's current policy at `zeta`: all terms of the theorem, and with
/// the policy held fixed.
pub fn exact_gradients<M: ModelMdp + ?Sized>(
    net: &M,
    learner: &Learner,
    zeta: &[f64],
    alpha: f64,
) -> (Vec<f64>, Vec<f64>) {
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
