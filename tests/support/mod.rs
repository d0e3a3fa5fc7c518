//! Helpers shared by the integration tests.
#![allow(dead_code)]

pub mod launch;

use envpg_ac::AcConfig;
use envpg_ac::trainer::RunSpec;
use envpg_core::{InstanceFile, LoadedEnv, Registry};
use envpg_envs::uav::{GenerateSpec, UavInstance, generate};

/// The built-in environments.
pub fn registry() -> Registry {
    envpg_envs::registry()
}

/// A small clustered instance: `users` users, `uavs` UAVs.
pub fn tiny_instance(users: usize, uavs: usize, seed: u64) -> UavInstance {
    generate(&GenerateSpec {
        name: format!("tiny-{users}-{uavs}"),
        n_users: users,
        n_uav: uavs,
        clusters: 3,
        side: 10.0,
        spread: 0.8,
        seed,
    })
    .expect("valid instance")
}

/// A small, fast configuration of Algorithm 1.
pub fn small_config(iterations: usize) -> AcConfig {
    AcConfig {
        iterations,
        episodes: 16,
        explore_episodes: 8,
        hidden: vec![32],
        batch: 128,
        warmup: 50,
        eval_every: 50,
        polish_iterations: 3,
        polish_episodes: 64,
        polish_policy_rounds: 1,
        polish_policy_samples: 64,
        polish_candidates: 2,
        polish_screen: 2,
        ..AcConfig::default()
    }
}

/// The tiny UAV instance (20 users, 3 UAVs) at `kappa`.
pub fn tiny_env(kappa: f64) -> LoadedEnv {
    let text = tiny_instance(20, 3, 5).to_json_pretty();
    registry().build(InstanceFile::parse(&text, "<tiny>").unwrap(), &[("kappa".into(), kappa)]).unwrap()
}

/// A run specification on a tiny instance.
pub fn tiny_spec(kappa: f64, seed: u64, iterations: usize) -> RunSpec {
    RunSpec::new(&tiny_env(kappa), seed, small_config(iterations))
}
