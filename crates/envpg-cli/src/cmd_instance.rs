//! `envpg instance`.

use anyhow::{Context, Result};
use clap::Subcommand;
use envpg_core::policy::row_states;
use envpg_envs::uav::{GenerateSpec, generate};

use crate::args::{InstanceArgs, Tools};

/// Instance tools.
#[derive(Debug, Subcommand)]
pub enum InstanceCmd {
    /// Generate a seeded UAV instance with clustered users.
    Generate {
        /// Number of users.
        #[arg(long, default_value_t = 271)]
        users: usize,
        /// Number of UAVs (2..=32).
        #[arg(long, default_value_t = 5)]
        uavs: usize,
        /// Number of user clusters.
        #[arg(long, default_value_t = 6)]
        clusters: usize,
        /// Side of the square region.
        #[arg(long, default_value_t = 10.0)]
        side: f64,
        /// Standard deviation of users around their cluster centre.
        #[arg(long, default_value_t = 0.6)]
        spread: f64,
        /// Seed.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Instance name [default: gen-<users>u-<uavs>m-s<seed>].
        #[arg(long)]
        name: Option<String>,
        /// Output file (stdout if absent).
        #[arg(long)]
        out: Option<std::path::PathBuf>,
    },
    /// Validate an instance file (or a bundled instance's name) and print a summary of its
    /// environment.
    Check {
        /// The instance.
        file: String,
        /// Override a parameter: `--env-param kappa=0.9` (repeatable).
        #[arg(long = "env-param", value_name = "KEY=VALUE")]
        env_params: Vec<String>,
    },
}

/// Runs an instance subcommand.
pub fn run(cmd: InstanceCmd, tools: &Tools) -> Result<()> {
    match cmd {
        InstanceCmd::Generate { users, uavs, clusters, side, spread, seed, name, out } => {
            let spec = GenerateSpec {
                name: name.unwrap_or_else(|| format!("gen-{users}u-{uavs}m-s{seed}")),
                n_users: users,
                n_uav: uavs,
                clusters,
                side,
                spread,
                seed,
            };
            let inst = generate(&spec)?;
            let text = inst.to_json_pretty();
            match out {
                Some(p) => {
                    envpg_core::io::write_atomic(&p, text.as_bytes())
                        .with_context(|| format!("writing {}", p.display()))?;
                    println!("wrote {} ({} users, {} UAVs)", p.display(), inst.n_users(), inst.n_uav);
                }
                None => println!("{text}"),
            }
        }
        InstanceCmd::Check { file, env_params } => {
            let instance = InstanceArgs { instance: file, env_params, kappa: None, eta: None };
            let env = instance.load(&tools.registry)?;
            let s = env.sampler();
            let space = s.zeta_space();
            let bounded = if space.is_bounded() { "bounded" } else { "unbounded" };
            println!(
                "{}: ok — environment `{}`, name {:?}, {}; {} states ({} non-terminal), {} actions, γ = {}, ζ ∈ ℝ^{} ({bounded}: {}), {}",
                instance.instance,
                env.name,
                env.title,
                env.params_text(),
                s.n_states(),
                row_states(s).len(),
                s.n_actions(),
                s.gamma(),
                s.zeta_dim(),
                space.names().join(", "),
                if env.env.model().is_some() { "with a model" } else { "no model" }
            );
        }
    }
    Ok(())
}
