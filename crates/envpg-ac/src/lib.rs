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
pub use features::{Features, ZetaInput};
pub use learner::{Batch, Learner, LearnerError, LearnerState, Stats};
pub use nets::ActionSets;
pub use presets::Presets;
pub use rollout::{Episode, EpisodeKind};
pub use table::PolicyTable;
