//! Command-line options of a training run, turned into a validated [`RunSpec`].

use std::path::PathBuf;

use anyhow::{Result, bail};
use clap::{Args, ValueEnum};
use envpg_ac::trainer::RunSpec;
use envpg_ac::{AcConfig, ActorUpdate, CriticInit, StateOnehot, Zeta0, ZetaEstimator, ZetaInput, ZetaOptimizer};
use envpg_core::{LoadedEnv, Registry, ResultFile};

/// What to train: problem, seed, preset and per-setting overrides.
#[derive(Debug, Clone, Args)]
pub struct TrainArgs {
    /// Instance: a bundled one (`uav271`, `aac1800`, `flpo-n10m4`) or a path to an instance
    /// JSON file, which names its environment (`"env"`; none: `uav`).
    #[arg(long, default_value = "uav271")]
    pub instance: String,
    /// Override a parameter of the instance's environment: `--env-param deviation=0.3`
    /// (repeatable; the environment's parameters and defaults are listed by `envpg envs`).
    #[arg(long = "env-param", value_name = "KEY=VALUE")]
    pub env_params: Vec<String>,
    /// Shorthand for `--env-param kappa=K` (uav, flpo): probability that a hop reaches its
    /// intended target.
    #[arg(long)]
    pub kappa: Option<f64>,
    /// Shorthand for `--env-param eta=E` (uav, flpo): concentration of off-target moves.
    #[arg(long)]
    pub eta: Option<f64>,
    /// Run seed: network initialisation, ζ₀, every episode and minibatch stream.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Preset of Algorithm 1 settings (see launch/presets.toml) [default: the preset named like
    /// the environment (`uav`, `aac`), or `default` (the `uav` settings in the environment's
    /// units) for one without].
    #[arg(long)]
    pub preset: Option<String>,
    /// Preset file, searched before the program's and envpg's bundled presets (a preset may
    /// extend another with `base = "name"`).
    #[arg(long)]
    pub presets: Option<PathBuf>,
    /// Outer iterations k_max.
    #[arg(long)]
    pub iterations: Option<usize>,
    /// On-policy episodes per iteration M.
    #[arg(long)]
    pub episodes: Option<usize>,
    /// Exploration episodes per iteration (train critic and actor only).
    #[arg(long)]
    pub explore_episodes: Option<usize>,
    /// Uniform-action probability in exploration episodes.
    #[arg(long)]
    pub explore_eps: Option<f64>,
    /// Fraction of exploration episodes with an exploring start.
    #[arg(long)]
    pub explore_start: Option<f64>,
    /// Episode length cap.
    #[arg(long)]
    pub episode_cap: Option<usize>,
    /// σ of the per-step perturbation of ζ.
    #[arg(long)]
    pub sigma: Option<f64>,
    /// Iterations of the ζ polish after training: ζ refined for the greedy policy (improved
    /// along the way by `--polish-policy-rounds` rounds) by central differences of sampled
    /// episodes with common random numbers (0: none).
    #[arg(long)]
    pub polish_iterations: Option<usize>,
    /// Episodes per sampled-cost estimate of the polish.
    #[arg(long)]
    pub polish_episodes: Option<usize>,
    /// Half-width h of the polish's central differences.
    #[arg(long)]
    pub polish_h: Option<f64>,
    /// First step length of the polish.
    #[arg(long)]
    pub polish_step: Option<f64>,
    /// Rounds of sampled policy iteration on the policy during the polish (0: the actor's
    /// greedy policy stays frozen).
    #[arg(long, alias = "polish-routing")]
    pub polish_policy_rounds: Option<usize>,
    /// One-step samples per (state, action), and rollouts per state, of a policy round.
    #[arg(long, alias = "polish-routing-samples")]
    pub polish_policy_samples: Option<usize>,
    /// Starting designs of the polish: the final design and others around it; each is
    /// screened, and the one with the lowest sampled cost is polished (1: final design only).
    #[arg(long)]
    pub polish_candidates: Option<usize>,
    /// Standard deviation of the other polish starts' offsets from the final design.
    #[arg(long)]
    pub polish_spread: Option<f64>,
    /// Screening iterations per polish start.
    #[arg(long)]
    pub polish_screen: Option<usize>,
    /// Significance (standard errors of paired differences) the polish asks of every sampled
    /// improvement it accepts (0: any).
    #[arg(long)]
    pub polish_z: Option<f64>,
    /// σ at the last iteration as a fraction of --sigma (geometric over the ζ phase; 1 = constant).
    #[arg(long)]
    pub sigma_anneal: Option<f64>,
    /// Hidden widths, e.g. `64,64`.
    #[arg(long, value_delimiter = ',')]
    pub hidden: Option<Vec<usize>>,
    /// How ζ itself enters the networks: `routed` ((ζ − ζ_k)/scale in a slot of the pair's
    /// action and one of its state's design element), `centered` ((ζ − ζ_k)/scale), `absolute`,
    /// `none`.
    #[arg(long, value_enum)]
    pub zeta_input: Option<ZetaInputArg>,
    /// The states' one-hot columns: `per-state` (one each) or `per-element` (one per design
    /// element's states, one shared by the rest, which the environment's own features tell
    /// apart: θ no longer grows with the states).
    #[arg(long, value_enum)]
    pub state_onehot: Option<StateOnehotArg>,
    /// Critic learning rate.
    #[arg(long)]
    pub critic_lr: Option<f64>,
    /// Critic steps per iteration.
    #[arg(long)]
    pub critic_steps: Option<usize>,
    /// Minibatch size N.
    #[arg(long)]
    pub batch: Option<usize>,
    /// Polyak rate τ of the target critic.
    #[arg(long)]
    pub polyak: Option<f64>,
    /// Critic initialisation.
    #[arg(long, value_enum)]
    pub critic_init: Option<CriticInitArg>,
    /// Actor learning rate.
    #[arg(long)]
    pub actor_lr: Option<f64>,
    /// Actor steps per iteration.
    #[arg(long)]
    pub actor_steps: Option<usize>,
    /// Actor update: `pg` (the paper's) or `gibbs-fit`.
    #[arg(long, value_enum)]
    pub actor_update: Option<ActorUpdateArg>,
    /// Iterations before ζ moves.
    #[arg(long)]
    pub warmup: Option<usize>,
    /// ζ step size ι.
    #[arg(long)]
    pub zeta_lr: Option<f64>,
    /// ι decay factor per iteration after warm-up.
    #[arg(long)]
    pub zeta_lr_decay: Option<f64>,
    /// Clip the ζ-gradient estimate's norm (0: off).
    #[arg(long)]
    pub zeta_clip: Option<f64>,
    /// Report the average of ζ_k over this final fraction of the iterations (0: the last ζ).
    #[arg(long)]
    pub zeta_average: Option<f64>,
    /// ζ-gradient estimator: `sampled` (the paper's), `baseline`, `expected`, `corollary`.
    #[arg(long, value_enum)]
    pub zeta_estimator: Option<ZetaEstimatorArg>,
    /// Every this many iterations move one idle design element (a UAV, a facility) to where it
    /// would serve the costliest hop (0: never).
    #[arg(long)]
    pub relocate_every: Option<usize>,
    /// Idle means a recent visit rate below this fraction of the busiest element's.
    #[arg(long)]
    pub relocate_below: Option<f64>,
    /// Fraction of capped on-policy episodes above which the run is looping (1: ignore loops).
    #[arg(long)]
    pub loop_tolerance: Option<f64>,
    /// α factor applied while looping.
    #[arg(long)]
    pub alpha_backoff: Option<f64>,
    /// ζ update: `sgd` (the paper's step) or `adam`.
    #[arg(long, value_enum)]
    pub zeta_optimizer: Option<ZetaOptimizerArg>,
    /// Initial temperature α₀.
    #[arg(long)]
    pub alpha0: Option<f64>,
    /// Temperature factor per iteration υ (0: reach --alpha-final at the end).
    #[arg(long)]
    pub alpha_decay: Option<f64>,
    /// Final temperature (when υ is automatic).
    #[arg(long)]
    pub alpha_final: Option<f64>,
    /// Initial design: `random` (the environment's random design), `env` (its own starting
    /// design: for uav the relay chain from the users' centroid to the destination, also
    /// accepted as `users`; for flpo the benchmark's `initial_facilities`), `clustered` (one
    /// draw of its clustered design from the seed: for uav the users' k-means centres), d comma-separated
    /// numbers inside the design bounds, or a result file on the same instance (its `zeta0`).
    #[arg(long)]
    pub zeta0: Option<String>,
    /// Record the exact J of (ζ_k, greedy π_k) every this many iterations (reporting only).
    #[arg(long)]
    pub eval_every: Option<usize>,
    /// Policy lag: 0 samples iteration k's episodes with θ_k, ζ_k (the workers wait while the
    /// learner updates); 1 samples them with θ_{k−1}, ζ_{k−1}, so the learner updates on batch
    /// k while the workers sample batch k + 1. Either way the same seed gives the same result
    /// for any worker count.
    #[arg(long)]
    pub lag: Option<usize>,
}

/// `--zeta-input`.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum ZetaInputArg {
    /// Not an input.
    None,
    /// Centred on ζ_k.
    Centered,
    /// Absolute.
    Absolute,
    /// Centred, routed into per-action and per-source slots.
    Routed,
}

/// `--state-onehot`.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum StateOnehotArg {
    /// One column per state.
    PerState,
    /// One column per design element's states and one shared by the rest.
    PerElement,
}

/// `--zeta-optimizer`.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum ZetaOptimizerArg {
    /// Plain steps.
    Sgd,
    /// Adam.
    Adam,
}

/// `--critic-init`.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum CriticInitArg {
    /// Default initialisation.
    Default,
    /// Output bias at the first iteration's mean return.
    MeanReturn,
}

/// `--actor-update`.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum ActorUpdateArg {
    /// The paper's policy gradient.
    Pg,
    /// Cross-entropy fit to the critic's Gibbs policy.
    GibbsFit,
}

/// `--zeta-estimator`.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum ZetaEstimatorArg {
    /// The paper's estimator on the sampled action.
    Sampled,
    /// With the ζ-baseline.
    Baseline,
    /// Exact average over actions.
    Expected,
    /// The Gibbs corollary: policy held fixed.
    Corollary,
}

impl TrainArgs {
    /// The environment and the validated run specification.
    pub fn spec(&self, registry: &Registry) -> Result<(LoadedEnv, RunSpec)> {
        let overrides =
            envpg_core::instance::param_overrides(&self.env_params, self.kappa, self.eta).map_err(crate::InputError)?;
        let env = registry.load(&self.instance, &overrides)?;
        let mut c = AcConfig::for_env(registry, self.presets.as_deref(), self.preset.as_deref(), env.name)?;
        macro_rules! set {
            ($($f:ident),*) => { $( if let Some(v) = self.$f.clone() { c.$f = v; } )* };
        }
        set!(iterations, episodes, explore_episodes, explore_eps, explore_start, episode_cap, sigma, hidden);
        set!(sigma_anneal, polish_iterations, polish_episodes, polish_h, polish_step);
        set!(polish_policy_rounds, polish_policy_samples, polish_candidates, polish_spread, polish_screen, polish_z);
        set!(critic_lr, critic_steps, batch, polyak, actor_lr, actor_steps, warmup, zeta_lr, zeta_lr_decay);
        set!(zeta_clip, alpha0, alpha_decay, alpha_final, eval_every, relocate_every, relocate_below);
        set!(loop_tolerance, alpha_backoff, zeta_average, lag);
        if let Some(v) = self.zeta_input {
            c.zeta_input = match v {
                ZetaInputArg::None => ZetaInput::None,
                ZetaInputArg::Centered => ZetaInput::Centered,
                ZetaInputArg::Absolute => ZetaInput::Absolute,
                ZetaInputArg::Routed => ZetaInput::Routed,
            };
        }
        if let Some(v) = self.state_onehot {
            c.state_onehot = match v {
                StateOnehotArg::PerState => StateOnehot::PerState,
                StateOnehotArg::PerElement => StateOnehot::PerElement,
            };
        }
        if let Some(v) = self.zeta_optimizer {
            c.zeta_optimizer = match v {
                ZetaOptimizerArg::Sgd => ZetaOptimizer::Sgd,
                ZetaOptimizerArg::Adam => ZetaOptimizer::Adam,
            };
        }
        if let Some(v) = self.critic_init {
            c.critic_init = match v {
                CriticInitArg::Default => CriticInit::Default,
                CriticInitArg::MeanReturn => CriticInit::MeanReturn,
            };
        }
        if let Some(v) = self.actor_update {
            c.actor_update = match v {
                ActorUpdateArg::Pg => ActorUpdate::Pg,
                ActorUpdateArg::GibbsFit => ActorUpdate::GibbsFit,
            };
        }
        if let Some(v) = self.zeta_estimator {
            c.zeta_estimator = match v {
                ZetaEstimatorArg::Sampled => ZetaEstimator::Sampled,
                ZetaEstimatorArg::Baseline => ZetaEstimator::Baseline,
                ZetaEstimatorArg::Expected => ZetaEstimator::Expected,
                ZetaEstimatorArg::Corollary => ZetaEstimator::Corollary,
            };
        }
        if let Some(z) = &self.zeta0 {
            c.zeta0 = parse_zeta0(z, &env)?;
        }
        c.validate()?;
        c.validate_for(env.env.feature_map().as_deref())?;
        let spec = RunSpec::new(&env, self.seed, c);
        // ζ₀ is checked now (inside the bounds, an `env` design that exists), not by the workers.
        envpg_ac::zeta0::initial_design(env.sampler(), &spec.config.zeta0, spec.seed)
            .map_err(|e| crate::InputError(format!("--zeta0: {e}")))?;
        Ok((env, spec))
    }
}

/// `--zeta0`: `random`, `env` (or `users`), `clustered`, a result file on the same instance, or
/// numbers.
fn parse_zeta0(text: &str, env: &LoadedEnv) -> Result<Zeta0> {
    match text {
        "random" => return Ok(Zeta0::Random),
        "env" | "users" => return Ok(Zeta0::Env),
        "clustered" => return Ok(Zeta0::Clustered),
        _ => {}
    }
    if std::path::Path::new(text).is_file() {
        let r = ResultFile::load(text)?;
        if r.instance != env.instance {
            bail!(crate::InputError(format!(
                "--zeta0 {text}: computed on instance {:?} ({}), not {:?} ({})",
                r.instance_name(),
                r.env,
                env.title,
                env.name
            )));
        }
        return Ok(Zeta0::Given(r.zeta0));
    }
    let z: Vec<f64> = text.split(',').map(|t| t.trim().parse::<f64>()).collect::<Result<_, _>>().map_err(|_| {
        crate::InputError(format!("--zeta0 {text:?}: expected random, env, clustered, a result file or numbers"))
    })?;
    env.sampler().zeta_space().check(&z).map_err(|e| crate::InputError(format!("--zeta0: {e}")))?;
    Ok(Zeta0::Given(z))
}
