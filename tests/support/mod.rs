//! Helpers shared by the integration tests.
#![allow(dead_code)]

pub mod launch;

use envpg_ac::AcConfig;
use envpg_ac::trainer::RunSpec;
use envpg_core::Instance;
use envpg_core::instance::{GenerateSpec, generate};

/// A small clustered instance: `users` users, `uavs` UAVs.
pub fn tiny_instance(users: usize, uavs: usize, seed: u64) -> Instance {
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
        polish_routing: 1,
        polish_routing_samples: 64,
        polish_candidates: 2,
        polish_screen: 2,
        ..AcConfig::default()
    }
}

/// A run specification on a tiny instance.
pub fn tiny_spec(kappa: f64, seed: u64, iterations: usize) -> RunSpec {
    RunSpec { instance: tiny_instance(20, 3, 5), kappa, eta: 100.0, seed, config: small_config(iterations) }
}
