//! [`AcConfig`]: every setting of Algorithm 1, with defaults, validation and TOML presets.

use serde::{Deserialize, Serialize};

pub use crate::presets::{BUNDLED_PRESETS, DEFAULT_PRESET, PresetError};

/// How the actor follows the critic.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ActorUpdate {
    /// The paper's entropy-regularised policy gradient (eq. entropy_spg) on sampled actions:
    /// `Σ_t (Q_φ(s_t,a_t,ζ_k) + α) ∇θ ln π_θ(a_t|s_t,ζ_k)`.
    Pg,
    /// Fit π_θ(·|s,ζ) to the critic's Gibbs policy `∝ π_θ exp(−Q_φ/α)` by cross-entropy
    /// (the soft-optimal form of the paper's Remark); avoids the softmax-PG plateau.
    GibbsFit,
}

/// How the per-step ζ-gradient term is estimated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ZetaEstimator {
    /// The paper's eq. (entropy_envpg) on the sampled action:
    /// `∇ζ Q_φ(s,a,ζ) + ∇ζ ln π_θ(a|s,ζ) · Q_φ(s,a,ζ_k)`.
    Sampled,
    /// The same with the ζ-baseline: `Q_φ(s,a,ζ_k) − V(s)`, `V = Σ_a π Q_φ`, in the score term.
    Baseline,
    /// The exact average over actions: `∇ζ Σ_a π_θ(a|s,ζ) Q_φ(s,a,ζ)`.
    Expected,
    /// The Gibbs corollary (eq. gibbs_gradient): `Σ_a π_θ(a|s,ζ_k) ∇ζ Q_φ(s,a,ζ)` with the
    /// policy held fixed — exact when the actor is the soft-optimal Gibbs policy, for which the
    /// score term vanishes in expectation; drops the imperfect actor's reaction to ζ.
    Corollary,
}

/// How ζ follows its gradient estimate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ZetaOptimizer {
    /// The paper's step `ζ ← ζ − ι·ĝ` (after optional norm clipping).
    Sgd,
    /// Adam on ζ: per-coordinate normalised steps of about ι, so a coordinate whose gradient is
    /// small but consistent (a design element the policy barely uses yet) still moves.
    Adam,
}

/// How the critic starts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum CriticInit {
    /// Default initialisation (output ≈ 0: optimistic in a cost-minimising SSP).
    Default,
    /// Output scaled by the mean return R̄ of the first iteration's on-policy episodes and
    /// starting at R̄ (Q = R̄·network, network output bias 1).
    MeanReturn,
}

/// Where ζ₀ comes from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Zeta0 {
    /// The environment's random design (`ParamMdp::random_design`, stream `Zeta0` of the seed).
    Random,
    /// The environment's own initial design from observable data (`ParamMdp::heuristic_design`,
    /// no model involved).
    Env,
    /// One draw of the environment's clustered design (`ParamMdp::clustered_design`, stream
    /// `Zeta0` of the seed; for the UAV network the users' k-means centres), no model involved.
    Clustered,
    /// A given design.
    Given(Vec<f64>),
}

/// Settings of Algorithm 1. Defaults are the values with which the README's acceptance
/// figures were measured.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AcConfig {
    /// Outer iterations k_max.
    pub iterations: usize,
    /// On-policy episodes per iteration M (from μ, actions from π_θk at ζ_k).
    pub episodes: usize,
    /// Extra exploration episodes per iteration, used only to train critic and actor.
    pub explore_episodes: usize,
    /// Probability of a uniform action in exploration episodes.
    pub explore_eps: f64,
    /// Fraction of exploration episodes starting at a uniformly drawn non-initial state
    /// (exploring starts through the step interface).
    pub explore_start: f64,
    /// Episode length cap (steps).
    pub episode_cap: usize,
    /// Standard deviation σ of the per-step perturbation ζ_pert = ζ_k + N(0, σ²I).
    pub sigma: f64,
    /// σ at the last iteration as a fraction of `sigma`: σ shrinks geometrically over the
    /// ζ phase (after the warm-up) from `sigma` to `sigma_anneal · sigma`; 1 keeps it constant.
    pub sigma_anneal: f64,
    /// Hidden-layer widths of actor and critic.
    pub hidden: Vec<usize>,
    /// How ζ itself is fed to the networks.
    pub zeta_input: crate::features::ZetaInput,
    /// Which one-hot column each state has: one per state, or one per design element's states
    /// and one shared by the rest (which the environment's own features then tell apart).
    pub state_onehot: crate::features::StateOnehot,
    /// Critic learning rate (Adam).
    pub critic_lr: f64,
    /// Critic steps per iteration.
    pub critic_steps: usize,
    /// Minibatch size N.
    pub batch: usize,
    /// Polyak rate τ of the target critic: φ⁻ ← τφ + (1−τ)φ⁻.
    pub polyak: f64,
    /// Critic initialisation.
    pub critic_init: CriticInit,
    /// Actor learning rate (Adam).
    pub actor_lr: f64,
    /// Actor steps per iteration.
    pub actor_steps: usize,
    /// Actor update rule.
    pub actor_update: ActorUpdate,
    /// Iterations before ζ starts moving.
    pub warmup: usize,
    /// ζ step size ι.
    pub zeta_lr: f64,
    /// ι_k = zeta_lr · zeta_lr_decay^(k − warmup).
    pub zeta_lr_decay: f64,
    /// Clip the norm of the ζ-gradient estimate at this value (0: no clipping).
    pub zeta_clip: f64,
    /// The reported design is the average of ζ_k over this final fraction of the iterations
    /// (Polyak–Ruppert averaging of the noisy ζ iterates; 0 reports the last iterate).
    pub zeta_average: f64,
    /// ζ-gradient estimator.
    pub zeta_estimator: ZetaEstimator,
    /// ζ update rule.
    pub zeta_optimizer: ZetaOptimizer,
    /// Every this many iterations after warm-up, move one *idle* design element (one the
    /// on-policy episodes did not visit lately) to where the environment says it would serve
    /// the costliest on-policy hop (`ParamMdp::relocate`; 0: never). Moving an unused element
    /// does not change J, and it gives the gradient an element to work with; without it an
    /// element that loses its traffic stays unused (in the UAV network, the single-UAV trap).
    pub relocate_every: usize,
    /// A design element is idle when its recent visit rate is below this fraction of the
    /// busiest one's.
    pub relocate_below: f64,
    /// When more than this fraction of on-policy episodes hit the cap, the entropy term is paying
    /// for loops (the model-free face of soft SSP divergence; only with γ = 1): the ζ step is skipped
    /// and α is multiplied by `alpha_backoff` (1 disables both).
    pub loop_tolerance: f64,
    /// Extra temperature factor applied while looping.
    pub alpha_backoff: f64,
    /// Initial temperature α₀.
    pub alpha0: f64,
    /// Temperature factor per iteration υ; 0 means "reach `alpha_final` at the last iteration".
    pub alpha_decay: f64,
    /// Final temperature when `alpha_decay` is 0.
    pub alpha_final: f64,
    /// Initial design.
    pub zeta0: Zeta0,
    /// Iterations of the ζ polish after the last iteration ([`crate::polish`]; 0: none).
    pub polish_iterations: usize,
    /// Episodes per sampled-cost estimate of the polish.
    pub polish_episodes: usize,
    /// Half-width h of the polish's central differences.
    pub polish_h: f64,
    /// First step length of the polish (steps are normalised).
    pub polish_step: f64,
    /// Rounds of sampled policy iteration on the polish's policy, spread over its iterations
    /// (0: the policy stays the final actor's greedy policy).
    #[serde(alias = "polish_routing")]
    pub polish_policy_rounds: usize,
    /// One-step samples per (state, action), and rollouts per state, of a policy round.
    #[serde(alias = "polish_routing_samples")]
    pub polish_policy_samples: usize,
    /// Starting designs of the polish: the design Algorithm 1 ends with and
    /// `polish_candidates − 1` others around it (`polish_spread`), each with the actor's greedy
    /// policy at that design; each is screened for `polish_screen` iterations, and the one
    /// whose sampled cost is lowest is kept and polished (1: the final design only).
    pub polish_candidates: usize,
    /// Standard deviation of the other starts' offsets from the final design.
    pub polish_spread: f64,
    /// Screening iterations per start.
    pub polish_screen: usize,
    /// Significance the polish asks of every sampled improvement it accepts (a ζ step, a new
    /// policy, a state's switch of action), in standard errors of paired differences on common
    /// random numbers; 0 accepts any (right where sampled costs are precise, as in the UAV
    /// network; noisy one-step costs need it).
    pub polish_z: f64,
    /// Policy lag of the sampled batches: 0 samples iteration k's episodes with θ_k at ζ_k
    /// (synchronous: workers wait while the learner updates); 1 samples them with the weights,
    /// design and temperature of iteration k − 1 (iteration 0 with θ_0, ζ_0), so that a
    /// distributed learner updates on batch k while the workers sample batch k + 1. The lag is
    /// fixed, never "whichever batch finished first", so the result stays a function of the
    /// seed alone.
    pub lag: usize,
    /// Exact J of (ζ_k, greedy π) is recorded every this many iterations (reporting only).
    pub eval_every: usize,
    /// Settings in the environment's own units ([`AcConfig::resolve`]): temperatures
    /// (`alpha0`, `alpha_final`) in units of its cost scale C (`ParamMdp::cost_scale`), lengths
    /// (`sigma`, `polish_h`, `polish_step`, `polish_spread`) in units of its design scale L (the
    /// mean of `ZetaSpace::scale`), the ζ step size `zeta_lr` in L²/C and the clip `zeta_clip`
    /// in C/L — so one preset fits environments of any size; with γ < 1 the episode cap is at
    /// least 3/(1 − γ) steps (all but e⁻³ of the discounted cost). Off: the values are
    /// absolute.
    pub scale_free: bool,
}

impl Default for AcConfig {
    fn default() -> Self {
        Self {
            iterations: 2000,
            episodes: 32,
            explore_episodes: 16,
            explore_eps: 0.3,
            explore_start: 0.5,
            episode_cap: 25,
            sigma: 0.2,
            sigma_anneal: 1.0,
            hidden: vec![128],
            zeta_input: crate::features::ZetaInput::Routed,
            state_onehot: crate::features::StateOnehot::PerState,
            critic_lr: 1e-3,
            critic_steps: 2,
            batch: 256,
            polyak: 0.1,
            critic_init: CriticInit::MeanReturn,
            actor_lr: 1e-3,
            actor_steps: 1,
            actor_update: ActorUpdate::GibbsFit,
            warmup: 200,
            zeta_lr: 0.02,
            zeta_lr_decay: 1.0,
            zeta_clip: 2.0,
            zeta_average: 0.25,
            zeta_estimator: ZetaEstimator::Corollary,
            zeta_optimizer: ZetaOptimizer::Sgd,
            loop_tolerance: 0.05,
            alpha_backoff: 0.8,
            relocate_every: 50,
            relocate_below: 0.01,
            alpha0: 1.0,
            alpha_decay: 0.0,
            alpha_final: 0.01,
            zeta0: Zeta0::Random,
            polish_iterations: 80,
            polish_episodes: 2048,
            polish_h: 0.005,
            polish_step: 0.05,
            polish_policy_rounds: 8,
            polish_policy_samples: 1024,
            polish_candidates: 16,
            polish_spread: 0.3,
            polish_screen: 20,
            polish_z: 0.0,
            lag: 0,
            eval_every: 50,
            scale_free: false,
        }
    }
}

/// A setting is out of range.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("invalid setting `{field}`: {reason}")]
pub struct ConfigError {
    /// The setting.
    pub field: &'static str,
    /// What is wrong.
    pub reason: String,
}

impl AcConfig {
    /// The absolute settings for `env`: with [`AcConfig::scale_free`], temperatures, lengths,
    /// the ζ step size and its clip multiplied by the environment's units (see there);
    /// otherwise the settings themselves. Every process resolves the same way, bit for bit.
    pub fn resolve<E: envpg_core::ParamMdp + ?Sized>(&self, env: &E) -> AcConfig {
        if !self.scale_free {
            return self.clone();
        }
        let c = env.cost_scale();
        let scales = env.zeta_space().scale();
        let l = scales.iter().sum::<f64>() / scales.len().max(1) as f64;
        AcConfig {
            alpha0: self.alpha0 * c,
            alpha_final: self.alpha_final * c,
            sigma: self.sigma * l,
            polish_h: self.polish_h * l,
            polish_step: self.polish_step * l,
            polish_spread: self.polish_spread * l,
            zeta_lr: self.zeta_lr * l * l / c,
            zeta_clip: self.zeta_clip * c / l,
            episode_cap: if env.gamma() < 1.0 {
                self.episode_cap.max((3.0 / (1.0 - env.gamma())).ceil() as usize)
            } else {
                self.episode_cap
            },
            scale_free: false,
            ..self.clone()
        }
    }

    /// The temperature factor per iteration υ.
    pub fn upsilon(&self) -> f64 {
        if self.alpha_decay > 0.0 {
            self.alpha_decay
        } else if self.iterations <= 1 {
            1.0
        } else {
            (self.alpha_final / self.alpha0).powf(1.0 / (self.iterations - 1) as f64)
        }
    }

    /// First iteration whose ζ enters the reported average.
    pub fn average_from(&self) -> usize {
        ((1.0 - self.zeta_average) * self.iterations as f64).floor() as usize
    }

    /// The polish settings.
    pub fn polish(&self) -> crate::polish::PolishSettings {
        crate::polish::PolishSettings {
            iterations: self.polish_iterations,
            episodes: self.polish_episodes,
            h: self.polish_h,
            step: self.polish_step,
            episode_cap: self.episode_cap,
            policy_rounds: self.polish_policy_rounds,
            policy_samples: self.polish_policy_samples,
            candidates: self.polish_candidates,
            candidate_spread: self.polish_spread,
            screen_iterations: self.polish_screen,
            z: self.polish_z,
        }
    }

    /// σ of the per-step perturbation at iteration k (see [`AcConfig::sigma_anneal`]).
    pub fn sigma_at(&self, k: u64) -> f64 {
        if self.sigma_anneal == 1.0 || k <= self.warmup as u64 {
            return self.sigma;
        }
        let span = self.iterations.saturating_sub(1 + self.warmup).max(1) as f64;
        let t = ((k - self.warmup as u64) as f64 / span).min(1.0);
        self.sigma * self.sigma_anneal.powf(t)
    }

    /// α at iteration k of the nominal schedule (before any loop back-off).
    pub fn alpha_at(&self, k: usize) -> f64 {
        self.alpha0 * self.upsilon().powi(k as i32)
    }

    /// Checks every range.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let err = |field: &'static str, reason: String| Err(ConfigError { field, reason });
        let finite_pos = |x: f64| x.is_finite() && x > 0.0;
        let prob = |x: f64| x.is_finite() && (0.0..=1.0).contains(&x);
        if self.iterations == 0 {
            return err("iterations", "must be at least 1".into());
        }
        if self.episodes == 0 {
            return err("episodes", "must be at least 1".into());
        }
        if !prob(self.explore_eps) {
            return err("explore_eps", format!("must be in [0, 1], got {}", self.explore_eps));
        }
        if !prob(self.explore_start) {
            return err("explore_start", format!("must be in [0, 1], got {}", self.explore_start));
        }
        if self.episode_cap == 0 {
            return err("episode_cap", "must be at least 1".into());
        }
        if self.lag > 1 {
            return err("lag", format!("must be 0 or 1, got {}", self.lag));
        }
        if !(self.sigma.is_finite() && self.sigma >= 0.0) {
            return err("sigma", format!("must be finite and >= 0, got {}", self.sigma));
        }
        if self.polish_iterations > 0 && self.polish_episodes == 0 {
            return err("polish_episodes", "must be at least 1 when polish_iterations > 0".into());
        }
        if self.polish_policy_rounds > 0 && self.polish_policy_samples == 0 {
            return err("polish_policy_samples", "must be at least 1 when polish_policy_rounds > 0".into());
        }
        if !(1..=16).contains(&self.polish_candidates) {
            return err("polish_candidates", format!("must be in 1..=16, got {}", self.polish_candidates));
        }
        if !(self.polish_spread.is_finite() && self.polish_spread >= 0.0) {
            return err("polish_spread", format!("must be finite and >= 0, got {}", self.polish_spread));
        }
        if self.polish_candidates > 1 && self.polish_screen == 0 {
            return err("polish_screen", "must be at least 1 when polish_candidates > 1".into());
        }
        if !finite_pos(self.polish_h) {
            return err("polish_h", format!("must be finite and > 0, got {}", self.polish_h));
        }
        if !finite_pos(self.polish_step) {
            return err("polish_step", format!("must be finite and > 0, got {}", self.polish_step));
        }
        if !(self.polish_z.is_finite() && self.polish_z >= 0.0) {
            return err("polish_z", format!("must be finite and >= 0, got {}", self.polish_z));
        }
        if !(self.sigma_anneal > 0.0 && self.sigma_anneal <= 1.0) {
            return err("sigma_anneal", format!("must be in (0, 1], got {}", self.sigma_anneal));
        }
        if self.hidden.is_empty() || self.hidden.contains(&0) {
            return err("hidden", format!("needs at least one layer of positive width, got {:?}", self.hidden));
        }
        if !finite_pos(self.critic_lr) {
            return err("critic_lr", format!("must be finite and > 0, got {}", self.critic_lr));
        }
        if !finite_pos(self.actor_lr) {
            return err("actor_lr", format!("must be finite and > 0, got {}", self.actor_lr));
        }
        if self.batch == 0 {
            return err("batch", "must be at least 1".into());
        }
        if !(self.polyak.is_finite() && self.polyak > 0.0 && self.polyak <= 1.0) {
            return err("polyak", format!("must be in (0, 1], got {}", self.polyak));
        }
        if !(self.zeta_lr.is_finite() && self.zeta_lr >= 0.0) {
            return err("zeta_lr", format!("must be finite and >= 0, got {}", self.zeta_lr));
        }
        if !(self.zeta_lr_decay.is_finite() && self.zeta_lr_decay > 0.0 && self.zeta_lr_decay <= 1.0) {
            return err("zeta_lr_decay", format!("must be in (0, 1], got {}", self.zeta_lr_decay));
        }
        if !(self.zeta_clip.is_finite() && self.zeta_clip >= 0.0) {
            return err("zeta_clip", format!("must be finite and >= 0, got {}", self.zeta_clip));
        }
        if !(self.relocate_below.is_finite() && (0.0..1.0).contains(&self.relocate_below)) {
            return err("relocate_below", format!("must be in [0, 1), got {}", self.relocate_below));
        }
        if !(self.loop_tolerance.is_finite() && (0.0..=1.0).contains(&self.loop_tolerance)) {
            return err("loop_tolerance", format!("must be in [0, 1], got {}", self.loop_tolerance));
        }
        if !(self.alpha_backoff.is_finite() && self.alpha_backoff > 0.0 && self.alpha_backoff <= 1.0) {
            return err("alpha_backoff", format!("must be in (0, 1], got {}", self.alpha_backoff));
        }
        if !(self.zeta_average.is_finite() && (0.0..1.0).contains(&self.zeta_average)) {
            return err("zeta_average", format!("must be in [0, 1), got {}", self.zeta_average));
        }
        if !finite_pos(self.alpha0) {
            return err("alpha0", format!("must be finite and > 0, got {}", self.alpha0));
        }
        if !(self.alpha_decay.is_finite() && (0.0..=1.0).contains(&self.alpha_decay)) {
            return err("alpha_decay", format!("must be in (0, 1] (or 0 for automatic), got {}", self.alpha_decay));
        }
        if !(finite_pos(self.alpha_final) && self.alpha_final <= self.alpha0) {
            return err("alpha_final", format!("must be in (0, alpha0], got {}", self.alpha_final));
        }
        if self.eval_every == 0 {
            return err("eval_every", "must be at least 1".into());
        }
        if let Zeta0::Given(z) = &self.zeta0
            && let Some(i) = z.iter().position(|x| !x.is_finite())
        {
            return err("zeta0", format!("entry {i} is not finite"));
        }
        Ok(())
    }

    /// Checks the settings that depend on the environment: `state_onehot = per-element` needs
    /// the environment's own features (`feature_map`), which tell apart the states that share
    /// a column.
    pub fn validate_for(&self, feature_map: Option<&dyn envpg_core::FeatureMap>) -> Result<(), ConfigError> {
        if self.state_onehot == crate::features::StateOnehot::PerElement && feature_map.is_none() {
            return Err(ConfigError {
                field: "state_onehot",
                reason: "per-element needs an environment with its own features (Env::feature_map); without them \
                         the states outside the design elements could not be told apart"
                    .into(),
            });
        }
        Ok(())
    }

    /// Sets one setting by name from its text, as a preset file would (`sigma` / `0.1`,
    /// `hidden` / `[64, 64]`, `zeta_estimator` / `baseline`), and validates the result.
    pub fn set(&self, key: &str, value: &str) -> Result<Self, ConfigError> {
        let field = |reason: String| ConfigError { field: "set", reason };
        // The names the polish's policy rounds had before any environment could have a policy
        // other than a routing (preset files read them through serde aliases).
        let key = match key {
            "polish_routing" => "polish_policy_rounds",
            "polish_routing_samples" => "polish_policy_samples",
            k => k,
        };
        let mut table = toml::Table::try_from(self).map_err(|e| field(e.to_string()))?;
        if !table.contains_key(key) {
            let mut known: Vec<_> = table.keys().cloned().collect();
            known.sort();
            return Err(field(format!("unknown setting {key:?} (settings: {})", known.join(", "))));
        }
        // A bare word is a string (`baseline`); anything else is read as a TOML value.
        let parsed = toml::from_str::<toml::Table>(&format!("v = {value}"))
            .ok()
            .and_then(|mut t| t.remove("v"))
            .unwrap_or_else(|| toml::Value::String(value.to_owned()));
        table.insert(key.to_owned(), parsed);
        let cfg: AcConfig = toml::Value::Table(table)
            .try_into()
            .map_err(|e: toml::de::Error| field(format!("{key} = {value}: {}", e.message())))?;
        cfg.validate()?;
        Ok(cfg)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scale_free_settings_are_multiplied_by_the_environments_units() {
        // flpo: an SSP (γ = 1) whose design lives in the unit box.
        let reg = envpg_envs::registry();
        let env = reg.load("flpo-n10m4", &[]).unwrap();
        let net = env.sampler();
        let (c, l) = (net.cost_scale(), net.zeta_space().scale().iter().sum::<f64>() / net.zeta_dim() as f64);
        assert!(c > 0.0 && l > 0.0);
        let rel = AcConfig::bundled(crate::presets::DEFAULT_PRESET).unwrap();
        assert!(rel.scale_free);
        let abs = rel.resolve(net);
        assert!(!abs.scale_free);
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs();
        assert!(close(abs.alpha0, rel.alpha0 * c) && close(abs.alpha_final, rel.alpha_final * c));
        assert!(close(abs.sigma, rel.sigma * l) && close(abs.polish_h, rel.polish_h * l));
        assert!(close(abs.polish_step, rel.polish_step * l) && close(abs.polish_spread, rel.polish_spread * l));
        // A ζ step is lr · clip at most: a length, L times the relative one.
        assert!(close(abs.zeta_lr, rel.zeta_lr * l * l / c) && close(abs.zeta_clip, rel.zeta_clip * c / l));
        assert!(close(abs.zeta_lr * abs.zeta_clip, rel.zeta_lr * rel.zeta_clip * l));
        assert_eq!(abs.episode_cap, rel.episode_cap, "an SSP keeps its cap");
        // Resolving is idempotent and leaves absolute settings alone.
        assert_eq!(abs.resolve(net), abs);
        assert_eq!(AcConfig::default().resolve(net), AcConfig::default());
    }

    #[test]
    fn a_discounted_environment_gets_episodes_of_at_least_three_discount_horizons() {
        let reg = envpg_envs::registry();
        let env = reg.load("uav271", &[]).unwrap();
        let rel = AcConfig { episode_cap: 5, ..AcConfig::bundled(crate::presets::DEFAULT_PRESET).unwrap() };
        // uav271 is an SSP (γ = 1): the cap is the preset's.
        assert_eq!(env.sampler().gamma(), 1.0);
        assert_eq!(rel.resolve(env.sampler()).episode_cap, 5);
        struct Discounted<'a>(&'a dyn envpg_core::ParamMdp);
        impl envpg_core::ParamMdp for Discounted<'_> {
            fn n_states(&self) -> usize {
                self.0.n_states()
            }
            fn n_actions(&self) -> usize {
                self.0.n_actions()
            }
            fn zeta_space(&self) -> &envpg_core::ZetaSpace {
                self.0.zeta_space()
            }
            fn valid_actions(&self, s: usize) -> &[usize] {
                self.0.valid_actions(s)
            }
            fn is_terminal(&self, s: usize) -> bool {
                self.0.is_terminal(s)
            }
            fn gamma(&self) -> f64 {
                0.95
            }
            fn sample_initial(&self, rng: &mut envpg_core::EnvRng) -> usize {
                self.0.sample_initial(rng)
            }
            fn step(&self, s: usize, a: usize, z: &[f64], rng: &mut envpg_core::EnvRng) -> (usize, f64) {
                self.0.step(s, a, z, rng)
            }
        }
        // 3 / (1 − 0.95) = 60 stages carry all but e⁻³ of the discounted cost.
        assert_eq!(rel.resolve(&Discounted(env.sampler())).episode_cap, 60);
        assert_eq!(AcConfig { episode_cap: 80, ..rel }.resolve(&Discounted(env.sampler())).episode_cap, 80);
    }

    #[test]
    fn defaults_are_valid_and_alpha_reaches_its_final_value() {
        let c = AcConfig::default();
        c.validate().unwrap();
        assert!((c.alpha_at(c.iterations - 1) - c.alpha_final).abs() < 1e-12);
    }

    #[test]
    fn sigma_is_constant_through_the_warm_up_then_shrinks_to_its_final_fraction() {
        let c = AcConfig { iterations: 102, warmup: 1, sigma: 0.2, sigma_anneal: 0.25, ..Default::default() };
        c.validate().unwrap();
        assert_eq!((c.sigma_at(0), c.sigma_at(1)), (0.2, 0.2));
        assert!((c.sigma_at(51) - 0.1).abs() < 1e-12, "geometric: halfway is σ·√0.25");
        assert!((c.sigma_at(101) - 0.05).abs() < 1e-12);
        assert!((c.sigma_at(500) - 0.05).abs() < 1e-12, "held after the last iteration");
        assert_eq!(AcConfig::default().sigma_at(1999), AcConfig::default().sigma);
        for bad in [0.0, 1.5, f64::NAN] {
            let e = AcConfig { sigma_anneal: bad, ..Default::default() }.validate().unwrap_err();
            assert_eq!(e.field, "sigma_anneal");
        }
    }

    #[test]
    fn settings_are_set_by_name_from_text() {
        let c = AcConfig::default();
        assert_eq!(c.set("sigma", "0.1").unwrap().sigma, 0.1);
        assert_eq!(c.set("hidden", "[64, 32]").unwrap().hidden, [64, 32]);
        assert_eq!(c.set("zeta_estimator", "baseline").unwrap().zeta_estimator, ZetaEstimator::Baseline);
        assert_eq!(c.set("iterations", "7").unwrap().iterations, 7);
        assert_eq!(c.set("polish_routing", "3").unwrap().polish_policy_rounds, 3);
        assert!(c.set("sigmaa", "1").unwrap_err().reason.contains("unknown setting \"sigmaa\""));
        assert_eq!(c.set("sigma", "-1").unwrap_err().field, "sigma");
        assert!(c.set("iterations", "many").is_err());
        assert!(c.set("zeta_estimator", "best").is_err());
    }

    #[test]
    fn out_of_range_settings_are_named() {
        let bad = [
            AcConfig { sigma: f64::NAN, ..Default::default() },
            AcConfig { alpha0: -1.0, ..Default::default() },
            AcConfig { explore_eps: 1.5, ..Default::default() },
            AcConfig { polyak: 0.0, ..Default::default() },
            AcConfig { polish_candidates: 0, ..Default::default() },
            AcConfig { polish_spread: f64::NAN, ..Default::default() },
            AcConfig { polish_screen: 0, ..Default::default() },
            AcConfig { polish_policy_samples: 0, ..Default::default() },
            AcConfig { lag: 2, ..Default::default() },
        ];
        let fields: Vec<_> = bad.iter().map(|c| c.validate().unwrap_err().field).collect();
        assert_eq!(
            fields,
            [
                "sigma",
                "alpha0",
                "explore_eps",
                "polyak",
                "polish_candidates",
                "polish_spread",
                "polish_screen",
                "polish_policy_samples",
                "lag"
            ]
        );
    }
}
