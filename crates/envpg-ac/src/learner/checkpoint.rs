//! The learner's state between iterations: what a checkpoint holds and restores, and the
//! weights a lagged batch is sampled with.

use envpg_nn::Adam;
use serde::{Deserialize, Serialize};

use super::Learner;

/// Everything the learner carries between iterations (for checkpoints).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LearnerState {
    /// Iteration k (next batch expected).
    pub k: u64,
    /// ζ_k.
    pub zeta: Vec<f64>,
    /// α_k.
    pub alpha: f64,
    /// Actor parameters θ.
    pub actor: Vec<f32>,
    /// Critic parameters φ.
    pub critic: Vec<f32>,
    /// Target critic parameters φ⁻.
    pub target: Vec<f32>,
    /// Output scale of critic and target (Q = scale · network).
    pub q_scale: f32,
    /// Actor optimiser.
    pub actor_opt: Adam,
    /// Critic optimiser.
    pub critic_opt: Adam,
    /// ζ optimiser (Adam moments; unused by plain steps).
    pub zeta_opt: Adam,
    /// Recent on-policy visits of each state (exponential average), for idle relocation.
    pub visits: Vec<f64>,
    /// Running sum of the designs ζ_{k+1} entering the reported average, and their count.
    pub zeta_sum: Vec<f64>,
    /// Number of designs in `zeta_sum`.
    pub zeta_count: u64,
    /// With a policy lag, the weights the next batch is sampled with (see [`Behaviour`]).
    pub lagged: Option<Behaviour>,
}

/// [`LearnerState`] borrowed from the learner ([`Learner::state_ref`]): serialises to the same
/// bytes (serde writes a slice like a vector), so a checkpoint need not copy θ, φ, φ⁻ and their
/// optimisers first — tens of MB at 10,000 users.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct LearnerStateRef<'a> {
    k: u64,
    zeta: &'a [f64],
    alpha: f64,
    actor: &'a [f32],
    critic: &'a [f32],
    target: &'a [f32],
    q_scale: f32,
    actor_opt: &'a Adam,
    critic_opt: &'a Adam,
    zeta_opt: &'a Adam,
    visits: &'a [f64],
    zeta_sum: &'a [f64],
    zeta_count: u64,
    lagged: Option<&'a Behaviour>,
}

/// The weights a batch is sampled with when the run has a policy lag ([`AcConfig::lag`](crate::AcConfig::lag)): the
/// actor θ_{k−1}, design ζ_{k−1} and temperature α_{k−1} from before the last update.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Behaviour {
    /// Actor parameters.
    pub actor: Vec<f32>,
    /// Design.
    pub zeta: Vec<f64>,
    /// Temperature.
    pub alpha: f64,
}

/// What the next batch is sampled with ([`Learner::behaviour`]), borrowed from the learner.
#[derive(Debug, Clone, Copy)]
pub struct BehaviourRef<'a> {
    /// Actor parameters.
    pub actor: &'a [f32],
    /// Design.
    pub zeta: &'a [f64],
    /// Temperature.
    pub alpha: f64,
}

impl Learner {
    /// The learner's state for a checkpoint.
    pub fn state(&self) -> LearnerState {
        LearnerState {
            k: self.k,
            zeta: self.zeta.clone(),
            alpha: self.alpha,
            actor: self.actor.mlp.params().to_vec(),
            critic: self.critic.mlp.params().to_vec(),
            target: self.target.mlp.params().to_vec(),
            q_scale: self.critic.scale(),
            actor_opt: self.actor_opt.clone(),
            critic_opt: self.critic_opt.clone(),
            zeta_opt: self.zeta_opt.clone(),
            visits: self.visits.clone(),
            zeta_sum: self.zeta_sum.clone(),
            zeta_count: self.zeta_count,
            lagged: self.lagged.clone(),
        }
    }

    /// [`Learner::state`] without copying it: the same serialised bytes.
    pub fn state_ref(&self) -> LearnerStateRef<'_> {
        LearnerStateRef {
            k: self.k,
            zeta: &self.zeta,
            alpha: self.alpha,
            actor: self.actor.mlp.params(),
            critic: self.critic.mlp.params(),
            target: self.target.mlp.params(),
            q_scale: self.critic.scale(),
            actor_opt: &self.actor_opt,
            critic_opt: &self.critic_opt,
            zeta_opt: &self.zeta_opt,
            visits: &self.visits,
            zeta_sum: &self.zeta_sum,
            zeta_count: self.zeta_count,
            lagged: self.lagged.as_ref(),
        }
    }

    /// Restores a checkpointed state (same environment and configuration).
    pub fn restore(&mut self, st: LearnerState) -> Result<(), String> {
        let n_a = self.actor.mlp.n_params();
        let n_c = self.critic.mlp.n_params();
        if st.actor.len() != n_a || st.critic.len() != n_c || st.target.len() != n_c || st.zeta.len() != self.zeta.len()
        {
            return Err("checkpoint shapes do not match this configuration".into());
        }
        if st.actor_opt.m.len() != n_a || st.critic_opt.m.len() != n_c {
            return Err("checkpoint optimiser shapes do not match this configuration".into());
        }
        if let Some(b) = &st.lagged
            && (b.actor.len() != n_a || b.zeta.len() != self.zeta.len())
        {
            return Err("checkpoint behaviour weights do not match this configuration".into());
        }
        if st.lagged.is_some() != (self.cfg.lag > 0 && st.k > 0) {
            return Err("checkpoint policy lag does not match this configuration".into());
        }
        self.actor.mlp.set_params(&st.actor);
        self.critic.mlp.set_params(&st.critic);
        self.target.mlp.set_params(&st.target);
        self.critic.set_scale(st.q_scale);
        self.target.set_scale(st.q_scale);
        self.actor_opt = st.actor_opt;
        self.critic_opt = st.critic_opt;
        self.zeta_opt = st.zeta_opt;
        if st.visits.len() != self.visits.len() {
            return Err("checkpoint visit counts do not match this environment".into());
        }
        self.visits = st.visits;
        if st.zeta_sum.len() != self.zeta.len() {
            return Err("checkpoint design average does not match this environment".into());
        }
        self.zeta_sum = st.zeta_sum;
        self.zeta_count = st.zeta_count;
        self.lagged = st.lagged;
        self.zeta = st.zeta;
        self.features.set_center(&self.zeta);
        self.alpha = st.alpha;
        self.k = st.k;
        Ok(())
    }

    /// Sets the learner to train again from iteration `k` at design `zeta` (a warm start):
    /// the actor, critic, target, their optimisers and the visit averages are kept, so the
    /// policy carries over; α is the nominal schedule's α_k ([`AcConfig::alpha_at`](crate::AcConfig::alpha_at)); ζ's
    /// optimiser and the reported design average start anew, as at a new design. With a policy
    /// lag, the first batch is sampled with the kept actor at `zeta`.
    pub fn rewind(&mut self, k: u64, mut zeta: Vec<f64>) {
        assert_eq!(zeta.len(), self.zeta.len(), "zeta dimension");
        self.space.project(&mut zeta);
        self.k = k;
        self.alpha = self.cfg.alpha_at(k as usize);
        self.zeta_opt = Adam::new(zeta.len(), self.cfg.zeta_lr);
        self.zeta_sum.iter_mut().for_each(|s| *s = 0.0);
        self.zeta_count = 0;
        self.features.set_center(&zeta);
        self.lagged = (self.cfg.lag > 0 && k > 0).then(|| Behaviour {
            actor: self.actor.mlp.params().to_vec(),
            zeta: zeta.clone(),
            alpha: self.alpha,
        });
        self.zeta = zeta;
    }
}
