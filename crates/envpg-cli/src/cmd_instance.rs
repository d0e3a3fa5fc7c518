//! `envpg instance`.

use anyhow::{Context, Result};
use clap::Subcommand;
use envpg_core::instance::{GenerateSpec, generate};

use crate::args::load_instance;

/// Instance tools.
#[derive(Debug, Subcommand)]
pub enum InstanceCmd {
    /// Generate a seeded instance with clustered users.
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
    /// Validate an instance file and print a summary.
    Check {
        /// Instance file (or `uav271`).
        file: String,
    },
}

/// Runs an instance subcommand.
pub fn run(cmd: InstanceCmd) -> Result<()> {
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
        InstanceCmd::Check { file } => {
            let inst = load_instance(&file)?;
            let (lo, hi) = inst.user_bbox();
            println!(
                "{file}: ok — name {:?}, {} users in [{:.3}, {:.3}]×[{:.3}, {:.3}], {} UAVs, destination {:?}",
                inst.name,
                inst.n_users(),
                lo[0],
                hi[0],
                lo[1],
                hi[1],
                inst.n_uav,
                inst.dest
            );
        }
    }
    Ok(())
}
