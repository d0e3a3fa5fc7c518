//! # envpg-core
//!
//! The environment API of envpg: what a *finite parameterized MDP* is, how an environment is
//! registered and loaded from an instance file, reproducible random streams, and the
//! result-file schema. Environments themselves live elsewhere (`envpg-envs` for the built-in
//! ones, or a user's own crate).
//!
//! ## Main types
//! - [`ParamMdp`]: the black-box sampler — sizes, valid actions, initial states,
//!   `step(s, a, ζ, rng) -> (s', cost)`, γ, the design space, and optional hooks (exploring
//!   starts, initial designs, design elements). Model-free code (Algorithm 1) sees only this.
//! - [`ModelMdp`]: the optional model view of the same MDP — outcome probabilities, costs and
//!   their ζ-derivatives — for the exact evaluator and the oracle (`envpg-model`).
//! - [`ZetaSpace`]: ζ's dimension, coordinate names and box bounds.
//! - [`FeatureMap`]: an environment's own dense network inputs with their ζ-Jacobian.
//! - [`Env`]: a registered environment (sampler + optional model, features and [`Sketch`]).
//! - [`Registry`] / [`EnvSpec`] / [`LoadedEnv`]: environments by name; instances
//!   ([`instance::InstanceFile`]) name their environment and parameters.
//! - [`rng::Streams`]: version-stable ChaCha streams derived per (seed, purpose, iteration, episode).
//! - [`result::ResultFile`]: the `envpg.result.v2` JSON schema (v1 still read), written
//!   atomically by [`io::write_atomic`].
//!
//! ## Data flow
//! instance file → [`Registry::load`] → [`LoadedEnv`] (the environment and its canonical
//! instance) → either sampled by workers through [`ParamMdp::step`], or expanded into exact
//! transition tables by `envpg-model` through [`ModelMdp::outcomes`]. Every design produced
//! downstream is saved as a [`result::ResultFile`] carrying the canonical instance.
//!
//! ## Example: a two-state environment
//!
//! ```
//! use envpg_core::{EnvRng, ParamMdp, ZetaSpace};
//! use rand::RngExt;
//!
//! /// From state 0 one action leads to the terminal state 1; it costs (ζ − 1)², and with
//! /// probability ½ it takes a second step first.
//! struct Toy(ZetaSpace);
//!
//! impl ParamMdp for Toy {
//!     fn n_states(&self) -> usize { 2 }
//!     fn n_actions(&self) -> usize { 1 }
//!     fn zeta_space(&self) -> &ZetaSpace { &self.0 }
//!     fn valid_actions(&self, s: usize) -> &[usize] { if s == 0 { &[0] } else { &[] } }
//!     fn is_terminal(&self, s: usize) -> bool { s == 1 }
//!     fn sample_initial(&self, _rng: &mut EnvRng) -> usize { 0 }
//!     fn step(&self, _s: usize, _a: usize, zeta: &[f64], rng: &mut EnvRng) -> (usize, f64) {
//!         let next = if rng.random::<f64>() < 0.5 { 0 } else { 1 };
//!         (next, (zeta[0] - 1.0).powi(2))
//!     }
//! }
//!
//! let toy = Toy(ZetaSpace::new(vec!["z".into()], vec![-2.0], vec![2.0]).unwrap());
//! let mut rng = envpg_core::Streams::new(1).stream(envpg_core::Purpose::Other, 0, 0);
//! let (s, cost) = toy.step(0, 0, &[0.0], &mut rng);
//! assert!(s <= 1 && cost == 1.0);
//! ```

pub mod checks;
pub mod env;
pub mod exit;
pub mod features;
pub mod instance;
pub mod io;
pub mod mdp;
pub mod policy;
pub mod registry;
pub mod result;
pub mod rng;
pub mod zeta;

pub use env::{Env, Sketch, SketchArrow, SketchLandmark, SketchMarker, SketchPoint};
pub use features::FeatureMap;
pub use instance::{InstanceError, InstanceFile, ParamSpec};
pub use mdp::{DesignElement, EnvRng, ModelMdp, OracleHints, Outcomes, ParamMdp};
pub use registry::{EnvSpec, LoadedEnv, NoModel, Registry};
pub use result::ResultFile;
pub use rng::{Purpose, StreamRng, Streams};
pub use zeta::{ZetaError, ZetaSpace};
