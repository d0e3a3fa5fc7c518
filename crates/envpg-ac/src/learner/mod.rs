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
//!
//! The update's parts sit beside it: the critic's and the actor's steps in `steps`, the EnvPG
//! estimate in `zeta`, the relocation of idle design elements in `relocate`, and what a
//! checkpoint holds ([`LearnerState`]) in `checkpoint`.

use std::sync::Arc;

use envpg_core::{DesignElement, FeatureMap, ParamMdp, Purpose, Streams, ZetaSpace};
use envpg_nn::{Adam, Mlp};
use serde::{Deserialize, Serialize};

use crate::config::{AcConfig, ActorUpdate, CriticInit, ZetaOptimizer};
use crate::features::Features;
use crate::nets::{ActionSets, Columns, Net};
use crate::rollout::{Episode, EpisodeKind, episode_ids};
use crate::table::PolicyTable;

mod checkpoint;
mod relocate;
mod steps;
mod zeta;

use zeta::zeta_gradient;

pub use checkpoint::{Behaviour, BehaviourRef, LearnerState, LearnerStateRef};

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
