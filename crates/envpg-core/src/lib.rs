//! # envpg-core
//!
//! The ground layer of envpg: what a *parameterized MDP* is, the UAV relay network of the
//! paper (Section V), instances, reproducible random streams and the result-file schema.
//!
//! ## Main types
//! - [`ParamMdp`]: the black-box sampler `step(s, a, ζ, rng) -> (s', cost)` plus valid actions,
//!   initial-state sampling and the terminal test. Model-free code (Algorithm 1) sees only this.
//! - [`ModelMdp`]: the model view of the same MDP — transition probabilities, costs and their
//!   derivatives with respect to ζ — used by the exact evaluator and the oracle (`envpg-model`).
//! - [`Observable`]: the coordinates a learner may observe (state and action-target positions,
//!   which for UAVs are read from ζ) and which ζ entries they come from.
//! - [`uav::UavNetwork`]: the relay network (users, UAVs = ζ, destination) implementing all three.
//! - [`instance::Instance`]: validated instance files; [`instance::generate`] for seeded scale studies.
//! - [`rng::Streams`]: version-stable ChaCha streams derived per (seed, purpose, iteration, episode).
//! - [`result::ResultFile`]: the `envpg.result.v1` JSON schema, written atomically by [`io::write_atomic`].
//!
//! ## Data flow
//! instance file → [`instance::Instance`] → [`uav::UavNetwork`] (with κ, η) → either sampled by
//! workers through [`ParamMdp::step`], or expanded into exact transition tables by `envpg-model`
//! through [`ModelMdp::outcomes`]. Every design produced downstream is saved as a [`result::ResultFile`].

pub mod instance;
pub mod io;
pub mod mdp;
pub mod result;
pub mod rng;
pub mod uav;

pub use instance::{Instance, InstanceError};
pub use mdp::{ModelMdp, Observable, Outcomes, ParamMdp};
pub use result::ResultFile;
pub use rng::{Purpose, Streams};
pub use uav::{UavNetwork, UavParamError};
