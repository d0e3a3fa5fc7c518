//! `envpg envs`: the registered environments, their parameters and the bundled instances.

use anyhow::Result;

use crate::args::Tools;

/// Prints every registered environment with its parameters, and the bundled instances.
pub fn run(tools: &Tools) -> Result<()> {
    for (name, about, params) in tools.registry.envs() {
        println!("{name}: {about}");
        for p in params {
            println!("    {:<12} default {:<8} {}", p.name, p.default, p.about);
        }
    }
    let bundled = tools.registry.bundled();
    if !bundled.is_empty() {
        println!("bundled instances (--instance NAME): {}", bundled.join(", "));
    }
    Ok(())
}
