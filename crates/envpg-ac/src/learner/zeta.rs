//! The EnvPG estimate of ∇ζ J_H from the on-policy episodes: the critic's and the actor's
//! gradients with respect to their dense inputs, chained through the feature map to ζ.

use super::Learner;
use crate::config::ZetaEstimator;
use crate::features::Features;
use crate::nets::{ActionSets, Columns, Net, softmax};
use crate::rollout::Episode;

impl Learner {
    /// Columns of every valid action of every on-policy step at `zeta`, and per step
    /// `(first column, number of actions, index of the taken action, γ^t)`.
    pub(super) fn on_policy_columns(&self, on: &[&Episode], zeta: &[f64]) -> (Columns, Vec<Taken>) {
        on_policy_columns(&self.features, &self.sets, on, zeta, self.gamma)
    }

    /// The EnvPG estimate of ∇ζ J_H(π_θk, ζ_k) from the on-policy episodes (eq. entropy_envpg),
    /// averaged over episodes, with the configured per-step estimator.
    pub fn zeta_gradient(&mut self, on: &[&Episode]) -> Vec<f64> {
        self.zeta_gradient_with(on, self.cfg.zeta_estimator)
    }

    /// `Σ w · ∇ζ Q_φ(s, a, ζ_k)` over the given `(s, a, w)`: weighted by exact visits it is the
    /// critic's version of the fixed-policy gradient, free of sampling noise (the critic audit).
    pub fn critic_zeta_gradient(&mut self, pairs: &[(usize, usize, f64)]) -> Vec<f64> {
        let mut cols = Columns::with_capacity(&self.features, pairs.len());
        for &(s, a, _) in pairs {
            cols.push(&self.features, s, a, &self.zeta, 0);
        }
        // The forward pass keeps the activations that backprop reads.
        let mut q = Vec::new();
        self.critic.eval(&cols, &mut q);
        let mut g = vec![0.0; self.zeta.len()];
        let ones = vec![1.0f32; cols.len()];
        add_input_gradient(&self.critic, &self.features, &cols, &ones, &self.zeta, |c| pairs[c].2, &mut g);
        g
    }

    /// [`Learner::zeta_gradient`] with an explicit estimator (for variance studies).
    pub fn zeta_gradient_with(&mut self, on: &[&Episode], estimator: ZetaEstimator) -> Vec<f64> {
        let gamma = self.gamma;
        zeta_gradient(&mut self.actor, &mut self.critic, &self.features, &self.sets, &self.zeta, on, estimator, gamma)
    }
}

/// One on-policy step's columns: (first column, number of actions, index of the taken action,
/// its discount γ^t).
pub(super) type Taken = (usize, usize, usize, f64);

/// Columns of every valid action of every on-policy step at `zeta`, and per step its [`Taken`].
fn on_policy_columns(
    features: &Features,
    sets: &ActionSets,
    on: &[&Episode],
    zeta: &[f64],
    gamma: f64,
) -> (Columns, Vec<Taken>) {
    let n = on.iter().flat_map(|ep| &ep.s).map(|&s| sets.of(s as usize).len()).sum();
    let mut cols = Columns::with_capacity(features, n);
    let mut taken = Vec::new();
    for ep in on {
        let mut disc = 1.0;
        for t in 0..ep.len() {
            let s = ep.s[t] as usize;
            let acts = sets.of(s);
            let start = cols.len();
            for &a in acts {
                cols.push(features, s, a, zeta, 0);
            }
            let k = acts.iter().position(|&a| a == ep.a[t] as usize).expect("validated");
            taken.push((start, acts.len(), k, disc));
            disc *= gamma;
        }
    }
    (cols, taken)
}

/// The EnvPG estimate with networks passed explicitly, so it can run beside the actor step;
/// step t of an episode is weighted by γ^t.
#[allow(clippy::too_many_arguments)]
pub(super) fn zeta_gradient(
    actor: &mut Net,
    critic: &mut Net,
    features: &Features,
    sets: &ActionSets,
    zeta: &[f64],
    on: &[&Episode],
    estimator: ZetaEstimator,
    gamma: f64,
) -> Vec<f64> {
    let d = zeta.len();
    let (cols, taken) = on_policy_columns(features, sets, on, zeta, gamma);
    let (mut logits, mut q) = (Vec::new(), Vec::new());
    actor.eval(&cols, &mut logits);
    critic.eval(&cols, &mut q);
    let scale = 1.0 / on.len() as f64;
    let mut d_critic = vec![0.0f32; cols.len()];
    let mut d_actor = vec![0.0f32; cols.len()];
    let mut pi = Vec::new();
    for &(r0, m, kt, disc) in &taken {
        pi.resize(m, 0.0);
        softmax(&logits[r0..r0 + m], &mut pi);
        let qs: Vec<f64> = (0..m).map(|j| q[r0 + j] as f64).collect();
        let v: f64 = (0..m).map(|j| pi[j] * qs[j]).sum();
        for j in 0..m {
            let ind = if j == kt { 1.0 } else { 0.0 };
            let (dc, da) = match estimator {
                ZetaEstimator::Sampled => (ind, (ind - pi[j]) * qs[kt]),
                ZetaEstimator::Baseline => (ind, (ind - pi[j]) * (qs[kt] - v)),
                ZetaEstimator::Expected => (pi[j], pi[j] * (qs[j] - v)),
                ZetaEstimator::Corollary => (pi[j], 0.0),
            };
            d_critic[r0 + j] = (disc * dc) as f32;
            d_actor[r0 + j] = (disc * da) as f32;
        }
    }
    let mut g = vec![0.0; d];
    for (net, dout) in [(&*critic, &d_critic), (&*actor, &d_actor)] {
        // The corollary estimator has no actor term.
        if dout.iter().all(|&x| x == 0.0) {
            continue;
        }
        add_input_gradient(net, features, &cols, dout, zeta, |_| scale, &mut g);
    }
    g
}

/// Adds `Σ_c weight(c) · (∂features_c/∂ζ)ᵀ ∇_x (dout · net)(x_c)` into `g`: the upstream
/// gradient `dout` backpropagated to the dense inputs of each column, then through the feature
/// map to ζ. `net` must hold the forward pass of `cols`.
fn add_input_gradient(
    net: &Net,
    features: &Features,
    cols: &Columns,
    dout: &[f32],
    zeta: &[f64],
    weight: impl Fn(usize) -> f64,
    g: &mut [f64],
) {
    let dense = cols.width();
    let mut di = Vec::new();
    net.backprop(cols, dout, None, Some(&mut di));
    for (c, &(s, a)) in cols.sa.iter().enumerate() {
        features.chain(s as usize, a as usize, zeta, &di[c * dense..(c + 1) * dense], weight(c), g);
    }
}
