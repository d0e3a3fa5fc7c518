//! # envpg-ac
//!
//! Algorithm 1 of the paper, the EnvPG actor–critic, kept apart from the processes that run it.
//!
//! ## Main types
//! - [`AcConfig`]: every setting, with defaults, validation and the per-environment units
//!   ([`AcConfig::resolve`]); [`Presets`]: named settings in TOML files (a user's, the
//!   program's, envpg's), one preset extending another.
//! - [`Features`]: network inputs of (s, a, ζ) and the chain rule back to ζ.
//! - [`PolicyTable`]: π_θk(·|s, ζ_k) for all states — what rollouts sample from.
//! - [`rollout::run_episode`]: the worker algorithm; touches the environment only through
//!   `ParamMdp::step`, with one RNG stream per (seed, k, episode).
//! - [`Learner`]: the learner algorithm, `update(&Batch) -> Stats`: critic TD steps with a
//!   target critic, the EnvPG ζ-gradient estimate, the actor step, the ζ step, α decay.
//! - [`memory::retain_freed_memory`]: the allocator setting that processes running a
//!   [`Learner`] call first (speed only).
//! - [`polish::polish_candidates`]: after the last iteration, ζ refined for the greedy policy
//!   by common-random-number differences of sampled episodes, the policy improved by sampled
//!   policy iteration, from several starts of which the cheapest is kept (model-free, optional).
//! - [`trainer::train`]: the serial (in-process) wiring of rollouts and learner, with history
//!   and the result file.
//!
//! ## Data flow
//! learner state (θ_k, ζ_k, α_k) → [`PolicyTable`] → episodes (worker) → [`Batch`] ordered by
//! episode index → [`Learner::update`] → (θ_{k+1}, φ_{k+1}, ζ_{k+1}, α_{k+1}); after the last
//! iteration, the ζ polish and the result file ([`trainer::Recorder::finish`]).
//!
//! ```
//! use envpg_ac::AcConfig;
//! use envpg_ac::trainer::{RunSpec, train};
//!
//! let registry = envpg_envs::registry();
//! let env = registry.load("flpo-n10m4", &[])?;
//! let config = AcConfig {
//!     iterations: 30, episodes: 16, explore_episodes: 8, hidden: vec![32], batch: 128, warmup: 10,
//!     eval_every: 10, polish_iterations: 0, ..AcConfig::default()
//! };
//! let spec = RunSpec::new(&env, 3, config);
//! let mut seen = Vec::new();
//! let result = train(&spec, &registry, |p| { seen.push(p.k); true })?;
//! assert_eq!(seen, (0..30).collect::<Vec<u64>>());
//! assert_ne!(result.zeta, result.zeta0, "ζ is learned after the warm-up");
//! env.sampler().zeta_space().check(&result.zeta)?; // and stays inside the design bounds
//! // Exact J_H of the final design and soft policy (after 30 iterations the greedy one may loop).
//! assert!(result.j_h.is_some_and(|j| j.is_finite() && j > 0.0));
//! // The seed alone decides the run, bit for bit.
//! assert_eq!(train(&spec, &registry, |_| true)?.zeta, result.zeta);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod config;
pub mod exact;
pub mod features;
pub mod learner;
pub mod memory;
pub mod nets;
pub mod polish;
pub mod presets;
pub mod rollout;
pub mod study;
pub mod table;
pub mod trainer;
pub mod zeta0;

pub use config::{AcConfig, ActorUpdate, CriticInit, Zeta0, ZetaEstimator, ZetaOptimizer};
pub use features::{Features, StateOnehot, ZetaInput};
pub use learner::{Batch, Learner, LearnerError, LearnerState, Stats};
pub use nets::ActionSets;
pub use presets::Presets;
pub use rollout::{Episode, EpisodeKind};
pub use table::PolicyTable;
