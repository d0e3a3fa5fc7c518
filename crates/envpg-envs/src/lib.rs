//! # envpg-envs
//!
//! The environments envpg ships, each a finite parameterized MDP with sampler, model, design
//! bounds, features and a picture of its designs, registered under the name its instance files
//! use:
//!
//! | name | environment | design ζ | bundled instance |
//! |---|---|---|---|
//! | `uav` | [`uav::UavNetwork`]: the paper's UAV relay network | UAV positions | `uav271` |
//! | `aac` | [`aac::Aac`]: autonomy-aware clustering (arXiv 2509.25775) | cluster centres | `aac1800` |
//! | `flpo` | [`flpo::Flpo`]: facility location with path optimization (arXiv 2507.22338) | facility positions | `flpo-n10m4` |
//!
//! `uav` and `flpo` share the hop kernel of [`hop::HopNetwork`]; [`cluster::kmeans`] places the
//! UAV network's clustered designs. [`registry`] returns a
//! [`Registry`] with all three and their bundled instances; a program with environments of its
//! own adds them with [`Registry::register`].
//!
//! ```
//! let registry = envpg_envs::registry();
//! let env = registry.load("flpo-n10m4", &[("kappa".into(), 0.9)]).unwrap();
//! assert_eq!((env.name, env.param("kappa")), ("flpo", Some(0.9)));
//! assert!(env.model().is_ok());
//! ```

pub mod aac;
pub mod cluster;
pub mod flpo;
pub mod hop;
pub mod uav;

use envpg_core::Registry;

/// Largest number of design points (UAVs, facilities, cluster centres) an instance may have: ζ
/// travels in fixed-size protocol headers of 64 coordinates, and a larger count read from a
/// file is refused before anything is allocated for it.
pub const MAX_DESIGN_POINTS: usize = 32;

/// The name by which the paper's instance is selected on command lines.
pub const BUNDLED_UAV: &str = "uav271";

/// Every built-in environment, with the bundled instances `uav271`, `aac1800` and
/// `flpo-n10m4`.
pub fn registry() -> Registry {
    Registry::new()
        .register::<uav::UavNetwork>()
        .register::<aac::Aac>()
        .register::<flpo::Flpo>()
        .bundle(BUNDLED_UAV, uav::UAV271)
        .bundle("aac1800", aac::AAC1800)
        .bundle("flpo-n10m4", flpo::FLPO_N10M4)
}
