//! [`Learner`]: the learner side of Algorithm 1 as a pure state machine.
//!
//! `update(&Batch) -> Stats` takes the episodes of iteration k (generated with θ_k at ζ_k) and
//! performs, in order: the critic's TD steps with a Polyak-averaged target critic, the EnvPG
//! estimate of ∇ζ J_H(π_θk, ζ_k) (after warm-up), the actor step, the ζ step and the α decay.
//! It never steps the environment: it sees the transitions, the observable features and the
//! sampler's hooks (design elements and their relocation, the design bounds).
//!
//! With γ < 1 the J estimates and both gradient estimates weight step t by γ^t, and episodes
//! that reach the length cap are truncations, not loops.

use std::sync::Arc;

use envpg_core::{DesignElement, FeatureMap, ParamMdp, Purpose, Streams, ZetaSpace};
use envpg_nn::{Adam, Mlp};
use rand::RngExt;
use serde::{Deserialize, Serialize};

use crate::config::{AcConfig, ActorUpdate, CriticInit, ZetaEstimator, ZetaOptimizer};
use crate::features::Features;
use crate::nets::{ActionSets, Columns, Net, softmax};
use crate::rollout::{Episode, EpisodeKind, episode_ids};
use crate::table::PolicyTable;

/// Transitions (or states) per network evaluation over every valid action: bounds the columns
/// held at once — one per valid action, each with its dense features (with the routed ζ-block,
/// (actions + sources) × d floats: 6.7 KB a column at 10,000 users and 20 UAVs) — whatever the
/// batch (the whole batch at once held 220 MB there). A network
/// with one hidden layer (the default) evaluates its columns one by one, so chunking changes no
/// bit; the chunk is fixed, so results never depend on how the batch was gathered.
const EVAL_CHUNK: usize = 64;

/// The episodes of one iteration, ordered as [`episode_ids`].
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Batch {
    /// Iteration k.
    pub k: u64,
    /// Episodes, on-policy first, by index.
    pub episodes: Vec<Episode>,
}

/// What one update did.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Stats {
    /// Iteration k of the batch.
    pub k: u64,
    /// Temperature α_k used.
    pub alpha: f64,
    /// Mean over on-policy episodes of Σ_t (c_t + α ln π(a_t|s_t)): the learner's J_H estimate.
    pub j_h_estimate: f64,
    /// Mean on-policy episode cost (the learner's J estimate).
    pub j_estimate: f64,
    /// Critic loss of the last step.
    pub critic_loss: f64,
    /// Actor loss of the last step.
    pub actor_loss: f64,
    /// The ζ-gradient estimate (None during warm-up).
    pub zeta_grad: Option<Vec<f64>>,
    /// Its norm before clipping.
    pub grad_norm: Option<f64>,
    /// Transitions in the batch.
    pub transitions: usize,
    /// Mean on-policy episode length.
    pub mean_len: f64,
    /// Episodes that hit the cap.
    pub capped: usize,
    /// Design element (state) relocated this iteration, if any.
    pub relocated: Option<u32>,
    /// More on-policy episodes than tolerated hit the cap: ζ held, α backed off.
    pub looping: bool,
}

/// Why a batch was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LearnerError {
    /// The batch is for another iteration.
    #[error("batch is for iteration {got}, the learner is at {expected}")]
    WrongIteration {
        /// Learner's k.
        expected: u64,
        /// Batch's k.
        got: u64,
    },
    /// Episodes missing, duplicated or out of order.
    #[error("batch episodes do not match the iteration's episode set: {0}")]
    Episodes(String),
    /// A transition refers to an invalid state, action or design.
    #[error("invalid transition in episode {episode}: {reason}")]
    Transition {
        /// Episode index.
        episode: u32,
        /// What is wrong.
        reason: String,
    },
    /// The update produced a non-finite quantity: training has diverged, and ζ is left as it
    /// was before this iteration.
    #[error("Algorithm 1 diverged at iteration {k}: {what} is not finite")]
    Diverged {
        /// The iteration whose update diverged.
        k: u64,
        /// The quantity that is not finite.
        what: &'static str,
    },
}

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

/// The weights a batch is sampled with when the run has a policy lag ([`AcConfig::lag`]): the
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

/// The learner.
#[derive(Clone)]
pub struct Learner {
    /// The sampler, for its hooks only (relocation of idle design elements).
    env: Arc<dyn ParamMdp>,
    space: ZetaSpace,
    cfg: AcConfig,
    features: Features,
    sets: ActionSets,
    gamma: f64,
    streams: Streams,
    actor: Net,
    critic: Net,
    target: Net,
    actor_opt: Adam,
    critic_opt: Adam,
    zeta_opt: Adam,
    /// Recent on-policy visits per state.
    visits: Vec<f64>,
    zeta_sum: Vec<f64>,
    zeta_count: u64,
    /// The environment's design elements (points of ζ the process visits).
    elements: Vec<DesignElement>,
    zeta: Vec<f64>,
    alpha: f64,
    k: u64,
    /// With a policy lag, what the next batch is sampled with (set by every update).
    lagged: Option<Behaviour>,
    /// Reusable gradient buffers.
    actor_grad: Vec<f32>,
    critic_grad: Vec<f32>,
}

/// An actor forward pass over one actor minibatch (`idx`, in order): the columns of every valid
/// action of each transition and their logits; the activations stay in the actor's cache.
struct ActorPass {
    idx: Vec<usize>,
    cols: Columns,
    logits: Vec<f32>,
}

/// Flattened transitions of a batch.
#[derive(Default)]
struct Flat {
    s: Vec<usize>,
    a: Vec<usize>,
    s2: Vec<usize>,
    cost: Vec<f64>,
    zeta: Vec<f64>,
    on_policy: Vec<bool>,
}

impl std::fmt::Debug for Learner {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Learner").field("k", &self.k).field("alpha", &self.alpha).field("zeta", &self.zeta).finish()
    }
}

impl Learner {
    /// A fresh learner for `env` with design `zeta0`, on the default features or the
    /// environment's own (`feature_map`); networks are initialised from the `Init` stream of
    /// `seed`.
    pub fn new(
        env: Arc<dyn ParamMdp>,
        feature_map: Option<Arc<dyn FeatureMap>>,
        cfg: AcConfig,
        seed: u64,
        zeta0: Vec<f64>,
    ) -> Self {
        assert_eq!(zeta0.len(), env.zeta_dim(), "zeta0 dimension");
        let mut features = Features::with_state_onehot(&*env, feature_map, cfg.zeta_input, cfg.state_onehot);
        features.set_center(&zeta0);
        let sets = ActionSets::new(&*env);
        let streams = Streams::new(seed);
        let mut rng = streams.stream(Purpose::Init, 0, 0);
        let actor = Net::new(&features, &cfg.hidden, &mut rng, true);
        let critic = Net::new(&features, &cfg.hidden, &mut rng, cfg.critic_init == CriticInit::MeanReturn);
        let target = critic.clone();
        let actor_opt = Adam::new(actor.mlp.n_params(), cfg.actor_lr);
        let critic_opt = Adam::new(critic.mlp.n_params(), cfg.critic_lr);
        let alpha = cfg.alpha0;
        let zeta_opt = Adam::new(zeta0.len(), cfg.zeta_lr);
        Self {
            space: env.zeta_space().clone(),
            elements: env.design_elements(),
            zeta_opt,
            visits: vec![0.0; env.n_states()],
            zeta_sum: vec![0.0; zeta0.len()],
            zeta_count: 0,
            cfg,
            features,
            sets,
            gamma: env.gamma(),
            env,
            streams,
            actor,
            critic,
            target,
            actor_opt,
            critic_opt,
            zeta: zeta0,
            alpha,
            k: 0,
            lagged: None,
            actor_grad: Vec::new(),
            critic_grad: Vec::new(),
        }
    }

    /// Iteration k of the next batch.
    pub fn k(&self) -> u64 {
        self.k
    }
    /// ζ_k.
    pub fn zeta(&self) -> &[f64] {
        &self.zeta
    }

    /// The design to report: the average of the iterates since `average_from`, or ζ_k when
    /// none were averaged.
    pub fn reported_zeta(&self) -> Vec<f64> {
        if self.zeta_count == 0 {
            self.zeta.clone()
        } else {
            self.zeta_sum.iter().map(|s| s / self.zeta_count as f64).collect()
        }
    }
    /// α_k.
    pub fn alpha(&self) -> f64 {
        self.alpha
    }
    /// The actor θ_k.
    pub fn actor(&self) -> &Mlp<f32> {
        &self.actor.mlp
    }
    /// The critic φ_k.
    pub fn critic(&self) -> &Mlp<f32> {
        &self.critic.mlp
    }
    /// The configuration.
    pub fn config(&self) -> &AcConfig {
        &self.cfg
    }
    /// The feature map.
    pub fn features(&self) -> &Features {
        &self.features
    }
    /// The valid-action table.
    pub fn action_sets(&self) -> &ActionSets {
        &self.sets
    }

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
    /// policy carries over; α is the nominal schedule's α_k ([`AcConfig::alpha_at`]); ζ's
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

    /// The critic's Q_φ(s, a, ζ) over the valid actions of `s` (diagnostics and tests).
    pub fn q_values(&mut self, s: usize, zeta: &[f64]) -> Vec<f64> {
        let mut cols = Columns::default();
        for &a in self.sets.of(s) {
            cols.push(&self.features, s, a, zeta, 0);
        }
        let mut q = Vec::new();
        self.critic.values(&cols, &mut q);
        q.iter().map(|&x| x as f64).collect()
    }

    /// What the batch of iteration k is sampled with: θ_k, ζ_k, α_k, or with a policy lag
    /// ([`AcConfig::lag`]) those of iteration k − 1 (θ_0, ζ_0, α_0 for the first two batches).
    pub fn behaviour(&self) -> BehaviourRef<'_> {
        match &self.lagged {
            Some(b) => BehaviourRef { actor: &b.actor, zeta: &b.zeta, alpha: b.alpha },
            None => BehaviourRef { actor: self.actor.mlp.params(), zeta: &self.zeta, alpha: self.alpha },
        }
    }

    /// The policy of [`Learner::behaviour`] at its design: the table the batch of iteration k
    /// is sampled from (the same as [`Learner::policy_table`] without a lag).
    pub fn behaviour_table(&self) -> PolicyTable<'static> {
        match &self.lagged {
            Some(b) => {
                let mut actor = self.actor.mlp.clone();
                actor.set_params(&b.actor);
                PolicyTable::owned(&actor, &self.features, &self.sets, &b.zeta)
            }
            None => self.policy_table(),
        }
    }

    /// π_θk(·|·, ζ_k): what the workers sample from (rows are filled on demand). It holds its
    /// own copy of θ_k, so the learner can keep updating while it is in use.
    pub fn policy_table(&self) -> PolicyTable<'static> {
        PolicyTable::owned(&self.actor.mlp, &self.features, &self.sets, &self.zeta)
    }

    fn flatten(&self, batch: &Batch) -> Result<Flat, LearnerError> {
        let want: Vec<(EpisodeKind, u64)> = episode_ids(&self.cfg).collect();
        let got: Vec<(EpisodeKind, u64)> = batch.episodes.iter().map(|e| (e.kind(), e.index as u64)).collect();
        if want != got {
            return Err(LearnerError::Episodes(format!(
                "expected {} episodes in order, got {:?}…",
                want.len(),
                &got[..got.len().min(8)]
            )));
        }
        let d = self.zeta.len();
        let n_states = self.sets.n_states();
        let mut f = Flat::default();
        for ep in &batch.episodes {
            let bad = |reason: String| LearnerError::Transition { episode: ep.index, reason };
            let n = ep.len();
            if ep.a.len() != n || ep.s2.len() != n || ep.cost.len() != n || ep.zeta.len() != n * d {
                return Err(bad("ragged arrays".into()));
            }
            for t in 0..n {
                let (s, a, s2) = (ep.s[t] as usize, ep.a[t] as usize, ep.s2[t] as usize);
                if s >= n_states || s2 >= n_states || !self.sets.of(s).contains(&a) {
                    return Err(bad(format!("step {t}: ({s}, {a}, {s2}) is not a valid transition")));
                }
                let c = ep.cost[t] as f64;
                let z = &ep.zeta[t * d..(t + 1) * d];
                if !c.is_finite() || z.iter().any(|z| !z.is_finite()) {
                    return Err(bad(format!("step {t}: non-finite cost or design")));
                }
                f.s.push(s);
                f.a.push(a);
                f.s2.push(s2);
                f.cost.push(c);
                f.zeta.extend(z.iter().map(|&z| z as f64));
                f.on_policy.push(!ep.explore);
            }
        }
        Ok(f)
    }

    /// One iteration of Algorithm 1 on the episodes generated with θ_k at ζ_k (with a policy
    /// lag, with [`Learner::behaviour`]: θ_{k−1} at ζ_{k−1}).
    pub fn update(&mut self, batch: &Batch) -> Result<Stats, LearnerError> {
        if batch.k != self.k {
            return Err(LearnerError::WrongIteration { expected: self.k, got: batch.k });
        }
        let flat = self.flatten(batch)?;
        let cfg = self.cfg.clone();
        if cfg.lag > 0 {
            // Batch k + 1 is sampled with the weights this update starts from (copied into the
            // previous snapshot's buffers: no allocation per update).
            let b = self.lagged.get_or_insert_with(|| Behaviour { actor: Vec::new(), zeta: Vec::new(), alpha: 0.0 });
            b.actor.clear();
            b.actor.extend_from_slice(self.actor.mlp.params());
            b.zeta.clear();
            b.zeta.extend_from_slice(&self.zeta);
            b.alpha = self.alpha;
        }
        let d = self.zeta.len();
        let alpha = self.alpha;
        let mut table = self.policy_table();
        let on: Vec<&Episode> = batch.episodes.iter().filter(|e| !e.explore).collect();
        let n_on = on.len() as f64;
        let mut stats = Stats { k: self.k, alpha, transitions: flat.s.len(), ..Default::default() };
        for ep in &on {
            let mut ret = 0.0;
            let mut ret_h = 0.0;
            let mut disc = 1.0;
            for t in 0..ep.len() {
                let s = ep.s[t] as usize;
                let i = self.sets.of(s).iter().position(|&a| a == ep.a[t] as usize).expect("validated");
                ret += disc * ep.cost[t] as f64;
                ret_h += disc * (ep.cost[t] as f64 + alpha * table.of(s)[i].ln());
                disc *= self.gamma;
            }
            stats.j_estimate += ret / n_on;
            stats.j_h_estimate += ret_h / n_on;
            stats.mean_len += ep.len() as f64 / n_on;
        }
        stats.capped = batch.episodes.iter().filter(|e| e.capped).count();
        if self.k == 0 && cfg.critic_init == CriticInit::MeanReturn && stats.j_estimate.abs() > 0.0 {
            // Q = R̄·network with the network starting at 1: neither optimistic nor collapsing,
            // and O(1) network outputs whatever the scale of the costs.
            let scale = stats.j_estimate.abs() as f32;
            for net in [&mut self.critic, &mut self.target] {
                net.set_scale(scale);
                net.mlp.set_output_bias(stats.j_estimate.signum() as f32);
            }
        }
        // When the first actor minibatch holds every transition, its actor pass gives the
        // entropy terms of the TD targets too (the actor does not change before it): one pass
        // over the batch instead of two — where that pass gives the bits the separate
        // evaluation would, so that no result changes.
        let mut first_actor_pass = None;
        if !flat.s.is_empty() {
            let shared = cfg.actor_update == ActorUpdate::GibbsFit && cfg.actor_steps > 0 && cfg.batch >= flat.s.len();
            let ln_pi = if shared {
                let pass = self.actor_pass(&flat, 0);
                let ln_pi = if self.actor.mlp.eval_matches_forward(&pass.cols.inputs()) {
                    self.log_pi_of_pass(&flat, &pass)
                } else {
                    self.log_pi_at_pert(&flat)
                };
                first_actor_pass = Some(pass);
                ln_pi
            } else {
                self.log_pi_at_pert(&flat)
            };
            for step in 0..cfg.critic_steps {
                stats.critic_loss = self.critic_step(&flat, &ln_pi, &mut table, step);
            }
        }
        // Only an SSP loops: with γ < 1, a capped episode is a truncation.
        let capped_on = on.iter().filter(|e| e.capped).count();
        let looping =
            self.gamma == 1.0 && cfg.loop_tolerance < 1.0 && capped_on as f64 > cfg.loop_tolerance * on.len() as f64;
        stats.looping = looping;
        // The EnvPG estimate is for π_θk, so it uses a copy of the actor taken before the actor
        // step; the two are independent and run on two threads when the machine has them.
        let estimate = self.k >= cfg.warmup as u64 && !on.is_empty() && !looping;
        let mut nets = estimate.then(|| (self.actor.clone(), self.critic.clone()));
        let (features, sets, zeta) = (self.features.clone(), self.sets.clone(), self.zeta.clone());
        let grad = std::thread::scope(|scope| {
            let job = nets.as_mut().map(|(actor, critic)| {
                let on = &on;
                let (features, sets, zeta) = (&features, &sets, &zeta);
                let gamma = self.gamma;
                scope.spawn(move || zeta_gradient(actor, critic, features, sets, zeta, on, cfg.zeta_estimator, gamma))
            });
            if !flat.s.is_empty() {
                for step in 0..cfg.actor_steps {
                    stats.actor_loss = match cfg.actor_update {
                        ActorUpdate::GibbsFit => {
                            let pass = match first_actor_pass.take() {
                                Some(pass) => pass,
                                None => self.actor_pass(&flat, step),
                            };
                            self.actor_gibbs_step(&flat, pass)
                        }
                        ActorUpdate::Pg => self.actor_pg_step(&on),
                    };
                }
            }
            job.map(|h| h.join().expect("ζ-gradient thread"))
        });
        if !stats.critic_loss.is_finite() {
            return Err(LearnerError::Diverged { k: self.k, what: "the critic's TD loss" });
        }
        if let Some(g) = grad {
            let norm = g.iter().map(|x| x * x).sum::<f64>().sqrt();
            if !norm.is_finite() {
                return Err(LearnerError::Diverged { k: self.k, what: "the ζ-gradient estimate" });
            }
            let clip = if cfg.zeta_clip > 0.0 && norm > cfg.zeta_clip { cfg.zeta_clip / norm } else { 1.0 };
            let lr = cfg.zeta_lr * cfg.zeta_lr_decay.powf((self.k - cfg.warmup as u64) as f64);
            match cfg.zeta_optimizer {
                ZetaOptimizer::Sgd => {
                    for (z, gi) in self.zeta.iter_mut().zip(&g) {
                        *z -= lr * clip * gi;
                    }
                }
                ZetaOptimizer::Adam => {
                    self.zeta_opt.lr = lr;
                    let clipped: Vec<f64> = g.iter().map(|x| x * clip).collect();
                    self.zeta_opt.step(&mut self.zeta, &clipped);
                }
            }
            self.space.project(&mut self.zeta);
            stats.grad_norm = Some(norm);
            stats.zeta_grad = Some(g);
            self.features.set_center(&self.zeta);
        }
        stats.relocated = self.track_and_relocate(&on);
        if self.k as usize >= cfg.average_from() {
            for (s, z) in self.zeta_sum.iter_mut().zip(&self.zeta) {
                *s += z;
            }
            self.zeta_count += 1;
        }
        debug_assert_eq!(self.zeta.len(), d);
        self.k += 1;
        self.alpha *= cfg.upsilon() * if looping { cfg.alpha_backoff } else { 1.0 };
        Ok(stats)
    }

    /// Updates the visit averages with this iteration's on-policy states and, on schedule,
    /// moves the least-visited idle design element to where the environment says it would
    /// serve the costliest on-policy hop of this iteration ([`ParamMdp::relocate`]). The move is
    /// J-neutral (an unvisited element contributes nothing to J) and gives the gradient an
    /// element to work with: an idle element's ζ-gradient is exactly zero.
    fn track_and_relocate(&mut self, on: &[&Episode]) -> Option<u32> {
        const DECAY: f64 = 0.95;
        self.visits.iter_mut().for_each(|v| *v *= DECAY);
        let w = (1.0 - DECAY) / on.len().max(1) as f64;
        for ep in on {
            for &s in &ep.s {
                self.visits[s as usize] += w;
            }
        }
        let every = self.cfg.relocate_every as u64;
        if every == 0 || self.k < self.cfg.warmup as u64 || (self.k - self.cfg.warmup as u64) % every != every - 1 {
            return None;
        }
        let visits = |e: &DesignElement| e.states.iter().map(|&s| self.visits[s]).sum::<f64>();
        let busy_v = self.elements.iter().map(visits).fold(0.0, f64::max);
        let (idle, idle_v) =
            self.elements.iter().enumerate().map(|(i, e)| (i, visits(e))).min_by(|a, b| a.1.total_cmp(&b.1))?;
        if busy_v <= 0.0 || idle_v >= self.cfg.relocate_below * busy_v {
            return None;
        }
        // The costliest on-policy hop (observed cost between observed states).
        let mut best: Option<(f64, usize, usize)> = None;
        for ep in on {
            for t in 0..ep.len() {
                let c = ep.cost[t] as f64;
                if best.is_none_or(|b| c > b.0) {
                    best = Some((c, ep.s[t] as usize, ep.s2[t] as usize));
                }
            }
        }
        let (_, from, to) = best?;
        let element = &self.elements[idle];
        let coords = self.env.relocate(element, &self.zeta, from, to)?;
        for (c, z) in element.coords.clone().zip(coords) {
            self.zeta[c] = z;
            self.zeta_opt.m[c] = 0.0;
            self.zeta_opt.v[c] = 0.0;
        }
        self.space.project(&mut self.zeta);
        let share = self.cfg.relocate_below * busy_v / element.states.len() as f64;
        for &s in &element.states {
            self.visits[s] = share;
        }
        self.features.set_center(&self.zeta);
        Some(element.states[0] as u32)
    }

    /// ln π_θk(a_i|s_i, ζ_pert,i) for every transition (the entropy term of the TD targets).
    fn log_pi_at_pert(&mut self, f: &Flat) -> Vec<f64> {
        let d = self.zeta.len();
        let mut out = Vec::with_capacity(f.s.len());
        let (mut cols, mut logits, mut probs) = (Columns::default(), Vec::new(), Vec::new());
        for lo in (0..f.s.len()).step_by(EVAL_CHUNK) {
            let hi = (lo + EVAL_CHUNK).min(f.s.len());
            cols.clear();
            for i in lo..hi {
                for &a in self.sets.of(f.s[i]) {
                    cols.push(&self.features, f.s[i], a, &f.zeta[i * d..(i + 1) * d], i as u32);
                }
            }
            self.actor.values(&cols, &mut logits);
            let mut c = 0;
            for i in lo..hi {
                let acts = self.sets.of(f.s[i]);
                out.push(ln_pi_taken(acts, f.a[i], &logits[c..c + acts.len()], &mut probs));
                c += acts.len();
            }
        }
        out
    }

    /// `V⁻(s') = Σ_a' π_θk(a'|s', ζ_k) Q_φ⁻(s', a', ζ_k)` for the given states.
    fn target_values(&mut self, states: &[usize], table: &mut PolicyTable) -> Vec<f64> {
        let mut out = Vec::with_capacity(states.len());
        let (mut cols, mut q) = (Columns::default(), Vec::new());
        for chunk in states.chunks(EVAL_CHUNK) {
            cols.clear();
            for &s in chunk {
                for &a in self.sets.of(s) {
                    cols.push(&self.features, s, a, &self.zeta, 0);
                }
            }
            self.target.values(&cols, &mut q);
            let mut c = 0;
            out.extend(chunk.iter().map(|&s| {
                let p = table.of(s);
                let v: f64 = p.iter().zip(&q[c..c + p.len()]).map(|(p, q)| p * *q as f64).sum();
                c += p.len();
                v
            }));
        }
        out
    }

    /// Minibatch indices for learner purpose `(k, j)`: `min(N, n)` distinct transitions of the
    /// iteration's buffer (all of them, shuffled, when the buffer is smaller than N).
    fn minibatch(&self, n: usize, j: u64) -> Vec<usize> {
        let mut rng = self.streams.stream(Purpose::Minibatch, self.k, j);
        let take = self.cfg.batch.min(n);
        // Partial Fisher–Yates: the first `take` entries are a uniform sample without replacement.
        let mut idx: Vec<usize> = (0..n).collect();
        for i in 0..take {
            let j = rng.random_range(i..n);
            idx.swap(i, j);
        }
        idx.truncate(take);
        idx
    }

    /// One TD step of the critic and a Polyak update of the target; returns the loss.
    fn critic_step(&mut self, f: &Flat, ln_pi: &[f64], table: &mut PolicyTable, step: usize) -> f64 {
        let d = self.zeta.len();
        let idx = self.minibatch(f.s.len(), step as u64);
        // Distinct non-terminal successors, in first-seen order.
        let mut next_states: Vec<usize> = Vec::new();
        for &i in &idx {
            let s2 = f.s2[i];
            if !self.sets.terminal(s2) && !next_states.contains(&s2) {
                next_states.push(s2);
            }
        }
        let v = self.target_values(&next_states, table);
        let mut cols = Columns::with_capacity(&self.features, idx.len());
        let mut y = Vec::with_capacity(idx.len());
        for &i in &idx {
            let s2 = f.s2[i];
            let boot = if self.sets.terminal(s2) {
                0.0
            } else {
                v[next_states.iter().position(|&x| x == s2).expect("listed")]
            };
            y.push(f.cost[i] + self.alpha * ln_pi[i] + self.gamma * boot);
            cols.push(&self.features, f.s[i], f.a[i], &f.zeta[i * d..(i + 1) * d], i as u32);
        }
        let mut q = Vec::new();
        self.critic.eval(&cols, &mut q);
        let n = idx.len() as f64;
        let mut loss = 0.0;
        let dq: Vec<f32> = q
            .iter()
            .zip(&y)
            .map(|(&q, &y)| {
                let e = q as f64 - y;
                loss += e * e / n;
                (2.0 * e / n) as f32
            })
            .collect();
        let mut grad = std::mem::take(&mut self.critic_grad);
        grad.clear();
        grad.resize(self.critic.mlp.n_params(), 0.0);
        self.critic.backprop(&cols, &dq, Some(&mut grad), None);
        self.critic_opt.step(self.critic.mlp.params_mut(), &grad);
        self.critic_grad = grad;
        let tau = self.cfg.polyak as f32;
        for (t, s) in self.target.mlp.params_mut().iter_mut().zip(self.critic.mlp.params()) {
            *t = tau * s + (1.0 - tau) * *t;
        }
        loss
    }

    /// The actor's forward pass over actor step `step`'s minibatch: every valid action of each
    /// transition at its perturbed design, activations kept in the actor for the step's backprop.
    fn actor_pass(&mut self, f: &Flat, step: usize) -> ActorPass {
        let d = self.zeta.len();
        let idx = self.minibatch(f.s.len(), (self.cfg.critic_steps + step) as u64);
        let n = idx.iter().map(|&i| self.sets.of(f.s[i]).len()).sum();
        let mut cols = Columns::with_capacity(&self.features, n);
        for &i in &idx {
            for &a in self.sets.of(f.s[i]) {
                cols.push(&self.features, f.s[i], a, &f.zeta[i * d..(i + 1) * d], i as u32);
            }
        }
        let mut logits = Vec::new();
        self.actor.eval(&cols, &mut logits);
        ActorPass { idx, cols, logits }
    }

    /// [`Learner::log_pi_at_pert`] read off an actor pass that covers every transition.
    fn log_pi_of_pass(&self, f: &Flat, pass: &ActorPass) -> Vec<f64> {
        let mut out = vec![0.0; f.s.len()];
        let mut probs = Vec::new();
        let mut c = 0;
        for &i in &pass.idx {
            let acts = self.sets.of(f.s[i]);
            out[i] = ln_pi_taken(acts, f.a[i], &pass.logits[c..c + acts.len()], &mut probs);
            c += acts.len();
        }
        out
    }

    /// Cross-entropy fit of π_θ(·|s, ζ_pert) to the critic's Gibbs policy
    /// `∝ π_θ(a|s) exp(−Q_φ(s,a,ζ_pert)/α)` (Q_φ includes the current step's α ln π term, so this
    /// is `∝ exp(−Q̃/α)` with Q̃ the entropy-free action value), on the minibatch of `pass`
    /// (the actor's last forward pass).
    fn actor_gibbs_step(&mut self, f: &Flat, pass: ActorPass) -> f64 {
        let ActorPass { idx, cols, logits } = pass;
        let mut q = Vec::new();
        self.critic.values(&cols, &mut q);
        let n = idx.len() as f64;
        let mut dlogit = vec![0.0f32; cols.len()];
        let mut loss = 0.0;
        let (mut pi, mut target, mut z) = (Vec::new(), Vec::new(), Vec::new());
        let mut c = 0;
        for &i in &idx {
            let m = self.sets.of(f.s[i]).len();
            let r = c..c + m;
            pi.resize(m, 0.0);
            softmax(&logits[r.clone()], &mut pi);
            z.clear();
            z.extend(r.clone().map(|j| logits[j] - (q[j] as f64 / self.alpha) as f32));
            target.resize(m, 0.0);
            if z.iter().all(|v| v.is_finite()) {
                softmax(&z, &mut target);
            } else {
                // Q/α is beyond f32's range once the loop back-off has cooled α to ~1e-37 (or
                // to 0): the Gibbs policy is then its α → 0 limit.
                greedy(&q[r.clone()], &mut target);
            }
            for (j, col) in r.clone().enumerate() {
                dlogit[col] = ((pi[j] - target[j]) / n) as f32;
                if target[j] > 0.0 {
                    loss -= target[j] * pi[j].max(f64::MIN_POSITIVE).ln() / n;
                }
            }
            c += m;
        }
        self.actor_apply(&cols, &dlogit);
        loss
    }

    /// The paper's entropy-regularised policy gradient on the on-policy episodes at ζ_k:
    /// `∇θ J_H ≈ (1/M) Σ_episodes Σ_t γ^t (Q_φ(s_t,a_t,ζ_k) + α) ∇θ ln π_θ(a_t|s_t,ζ_k)`.
    fn actor_pg_step(&mut self, on: &[&Episode]) -> f64 {
        let zeta = self.zeta.clone();
        let (cols, taken) = self.on_policy_columns(on, &zeta);
        let (mut logits, mut q) = (Vec::new(), Vec::new());
        self.actor.eval(&cols, &mut logits);
        self.critic.values(&cols, &mut q);
        let m_eps = on.len() as f64;
        let mut dlogit = vec![0.0f32; cols.len()];
        let mut surrogate = 0.0;
        let mut pi = Vec::new();
        for &(r_start, m, k_taken, disc) in &taken {
            pi.resize(m, 0.0);
            softmax(&logits[r_start..r_start + m], &mut pi);
            let w = disc * (q[r_start + k_taken] as f64 + self.alpha);
            surrogate += w * pi[k_taken].max(f64::MIN_POSITIVE).ln() / m_eps;
            for j in 0..m {
                let ind = if j == k_taken { 1.0 } else { 0.0 };
                dlogit[r_start + j] = (w * (ind - pi[j]) / m_eps) as f32;
            }
        }
        self.actor_apply(&cols, &dlogit);
        surrogate
    }

    /// Backpropagates `dlogit` through the actor's last evaluation and takes an Adam step.
    fn actor_apply(&mut self, cols: &Columns, dlogit: &[f32]) {
        let mut grad = std::mem::take(&mut self.actor_grad);
        grad.clear();
        grad.resize(self.actor.mlp.n_params(), 0.0);
        self.actor.backprop(cols, dlogit, Some(&mut grad), None);
        self.actor_opt.step(self.actor.mlp.params_mut(), &grad);
        self.actor_grad = grad;
    }

    /// Columns of every valid action of every on-policy step at `zeta`, and per step
    /// `(first column, number of actions, index of the taken action, γ^t)`.
    fn on_policy_columns(&self, on: &[&Episode], zeta: &[f64]) -> (Columns, Vec<Taken>) {
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

/// `ln π(a|s)` from the logits of the valid actions `acts` of s (`probs` is scratch).
fn ln_pi_taken(acts: &[usize], a: usize, logits: &[f32], probs: &mut Vec<f64>) -> f64 {
    probs.resize(acts.len(), 0.0);
    softmax(logits, probs);
    let k = acts.iter().position(|&x| x == a).expect("validated");
    probs[k].max(f64::MIN_POSITIVE).ln()
}

/// One on-policy step's columns: (first column, number of actions, index of the taken action,
/// its discount γ^t).
type Taken = (usize, usize, usize, f64);

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
fn zeta_gradient(
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

/// The α → 0 limit of the Gibbs policy `exp(−Q/α)`: uniform over the actions of least Q.
fn greedy(q: &[f32], out: &mut [f64]) {
    let least = q.iter().fold(f32::INFINITY, |m, &v| m.min(v));
    let ties = q.iter().filter(|&&v| v == least).count() as f64;
    for (o, &v) in out.iter_mut().zip(q) {
        *o = if v == least { 1.0 / ties } else { 0.0 };
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rollout::run_iteration;
    use crate::trainer::{RunSpec, advance};

    /// A learner on uav271 with the `uav` preset (seed 3) after two iterations, with what
    /// advancing it further needs.
    fn uav271_after_two_iterations() -> (envpg_core::LoadedEnv, AcConfig, envpg_core::Streams, Learner) {
        let config = AcConfig::bundled("uav").expect("bundled preset");
        let env = envpg_envs::registry().load("uav271", &[]).expect("bundled instance");
        let spec = RunSpec::new(&env, 3, config.clone());
        let (_, mut learner) = spec.start_on(&env).expect("valid spec");
        let streams = envpg_core::Streams::new(spec.seed);
        advance(env.sampler(), &mut learner, &config, &streams, 2).expect("valid batches");
        (env, config, streams, learner)
    }

    #[test]
    fn the_shared_actor_pass_gives_the_entropy_terms_bit_for_bit() {
        let (env, config, streams, mut learner) = uav271_after_two_iterations();
        let mut table = learner.policy_table();
        let zeta = learner.zeta().to_vec();
        let sets = learner.action_sets().clone();
        let episodes = run_iteration(env.sampler(), &sets, &mut table, &zeta, &config, &streams, learner.k());
        let flat = learner.flatten(&Batch { k: learner.k(), episodes }).expect("valid batch");
        assert!(flat.s.len() <= config.batch, "the minibatch covers the buffer");
        let separate = learner.log_pi_at_pert(&flat);
        let pass = learner.actor_pass(&flat, 0);
        let shared = learner.log_pi_of_pass(&flat, &pass);
        assert!(learner.actor.mlp.eval_matches_forward(&pass.cols.inputs()));
        assert_eq!(pass.idx.len(), flat.s.len());
        assert!(separate.iter().all(|l| l.is_finite() && *l <= 0.0));
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&separate), bits(&shared));
    }

    #[test]
    fn a_rewound_learner_keeps_its_networks_and_trains_on_from_iteration_k_at_the_new_design() {
        let (env, config, streams, mut learner) = uav271_after_two_iterations();
        let before = learner.state();
        let mut zeta = before.zeta.clone();
        zeta[0] += 0.01;
        let k = config.average_from() as u64;
        learner.rewind(k, zeta.clone());
        let after = learner.state();
        // The policy and critic carry over, with their optimisers and the visit averages.
        assert_eq!((&after.actor, &after.critic, &after.target), (&before.actor, &before.critic, &before.target));
        assert_eq!(
            (&after.actor_opt, &after.critic_opt, &after.visits),
            (&before.actor_opt, &before.critic_opt, &before.visits)
        );
        // The schedule is the nominal one from k, at the new design, averaged anew.
        assert_eq!((after.k, after.alpha.to_bits()), (k, config.alpha_at(k as usize).to_bits()));
        assert!(after.alpha < before.alpha, "later in the schedule, cooler");
        assert_eq!(after.zeta, zeta);
        assert_eq!((after.zeta_count, after.zeta_sum.iter().all(|s| *s == 0.0)), (0, true));
        assert_eq!(after.zeta_opt, Adam::new(zeta.len(), config.zeta_lr));
        // It trains on from there, averaging from its first iteration (k = average_from).
        advance(env.sampler(), &mut learner, &config, &streams, 1).expect("valid batch");
        assert_eq!((learner.k(), learner.zeta_count), (k + 1, 1));
        assert_eq!(learner.reported_zeta(), learner.zeta());

        // With a policy lag, the rewound state is one a learner of that configuration restores.
        let lagged = AcConfig { lag: 1, ..config };
        let spec = RunSpec::new(&env, 3, lagged);
        let (_, mut a) = spec.start_on(&env).expect("valid spec");
        a.rewind(k, zeta.clone());
        assert_eq!(a.behaviour().zeta, &zeta[..], "the first batch is sampled at the new design");
        let (_, mut b) = spec.start_on(&env).expect("valid spec");
        b.restore(a.state()).expect("a consistent state");
        assert_eq!(b.state(), a.state());
    }

    #[test]
    fn a_temperature_cooled_below_f32s_range_fits_the_greedy_policy_instead_of_diverging() {
        let (env, config, streams, mut learner) = uav271_after_two_iterations();
        // What ~410 looping iterations of the ×0.8 back-off leave of α = 1: Q/α (Q ≈ 10) is
        // beyond f32's range.
        learner.alpha = 1e-38;
        assert!((10.0 / learner.alpha) as f32 == f32::INFINITY);
        advance(env.sampler(), &mut learner, &config, &streams, 3).expect("no divergence");
        assert!(learner.actor.mlp.params().iter().all(|p| p.is_finite()));
        assert!(learner.critic.mlp.params().iter().all(|p| p.is_finite()));
        // And in its limit α = 0 (the back-off's f64 underflow).
        learner.alpha = 0.0;
        advance(env.sampler(), &mut learner, &config, &streams, 2).expect("no divergence at α = 0");
        assert!(learner.actor.mlp.params().iter().all(|p| p.is_finite()));
    }
}
