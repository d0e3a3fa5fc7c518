//! `envpg plot`: figures from result files.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use envpg_core::ResultFile;
use envpg_report::figures::{PlotOptions, plot_results};

use crate::args::{Tools, input_err};

/// Options of `envpg plot`.
#[derive(Debug, Args)]
pub struct PlotArgs {
    /// Result files (envpg.result.v2, or v1) of Algorithm 1 runs and oracle runs, of any
    /// environments (grouped into columns by the instance parameters that differ).
    #[arg(required = true)]
    results: Vec<PathBuf>,
    /// Output directory.
    #[arg(long, default_value = "figures")]
    out: PathBuf,
    /// Moving-average window (iterations) of the per-iteration curves.
    #[arg(long, default_value_t = 100)]
    window: usize,
}

/// Renders every figure the results support.
pub fn run(a: PlotArgs, tools: &Tools) -> Result<()> {
    if a.window == 0 {
        return input_err("--window must be at least 1");
    }
    crate::args::check_dir_writable(&a.out)?;
    let results = a.results.iter().map(ResultFile::load).collect::<Result<Vec<_>, _>>()?;
    for (r, path) in results.iter().zip(&a.results) {
        r.load_env(&tools.registry, path)?;
    }
    for f in plot_results(&results, &tools.registry, &a.out, &PlotOptions { window: a.window })? {
        println!("wrote {}", f.display());
    }
    Ok(())
}
