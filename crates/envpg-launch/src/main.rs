//! `envpg-launch`: train with Algorithm 1.
//!
//! `--in-process` runs rollouts and learner in this process (`envpg_ac::trainer::train`).
//! Exit codes: 0 success, 1 the run failed, 2 bad input, 130 interrupted.

mod args;

use std::process::ExitCode;
use std::time::Duration;

use anyhow::{Context, Result};
use clap::Parser;
use indicatif::{ProgressBar, ProgressStyle};

/// Train a policy and the environment design together with the EnvPG actor–critic.
#[derive(Debug, Parser)]
#[command(name = "envpg-launch", version, about)]
struct Cli {
    #[command(flatten)]
    train: args::TrainArgs,
    /// Run rollouts and learner in this process.
    #[arg(long)]
    in_process: bool,
    /// Write the result file (envpg.result.v1) here.
    #[arg(long, default_value = "envpg-result.json")]
    out: std::path::PathBuf,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
}

/// Marks an error as bad input (exit code 2).
#[derive(Debug)]
struct InputError(String);

impl std::fmt::Display for InputError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for InputError {}

fn main() -> ExitCode {
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("warn"));
    let _ = tracing_subscriber::fmt().with_env_filter(filter).with_writer(std::io::stderr).try_init();
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            let input = e.chain().any(|c| {
                c.is::<InputError>()
                    || c.is::<envpg_core::InstanceError>()
                    || c.is::<envpg_core::result::ResultError>()
                    || c.is::<envpg_core::UavParamError>()
                    || c.is::<envpg_ac::config::ConfigError>()
                    || c.is::<envpg_ac::config::PresetError>()
            });
            ExitCode::from(if input { 2 } else { 1 })
        }
    }
}

fn progress_bar(total: u64, quiet: bool) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(total);
    bar.set_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:30}] {pos}/{len} {msg}")
            .expect("valid template")
            .progress_chars("=> "),
    );
    bar.enable_steady_tick(Duration::from_millis(200));
    bar
}

fn run(cli: Cli) -> Result<()> {
    // Everything that goes wrong while turning arguments into a run is the user's input.
    let spec = cli.train.spec().map_err(|e| InputError(format!("{e:#}")))?;
    if !cli.in_process {
        anyhow::bail!("worker processes are not available yet: use --in-process");
    }
    let bar = progress_bar(spec.config.iterations as u64, cli.quiet);
    let result = envpg_ac::trainer::train(&spec, |p| {
        bar.set_position(p.k + 1);
        bar.set_message(format!(
            "α={:.3e} J_H≈{:.3} J={} {:.0} tr/s",
            p.alpha,
            p.j_h_estimate,
            p.j_exact.map_or("-".into(), |j| format!("{j:.4}")),
            p.transitions_per_s
        ));
        true
    })?;
    bar.finish_and_clear();
    result.save(&cli.out).with_context(|| format!("writing {}", cli.out.display()))?;
    if !cli.quiet {
        println!(
            "J = {}  (J_H = {})  zeta = {}  {:.1}s  → {}",
            result.j.map_or("inf".into(), |j| format!("{j:.6}")),
            result.j_h.map_or("-".into(), |j| format!("{j:.6}")),
            result.zeta.iter().map(|z| format!("{z:.3}")).collect::<Vec<_>>().join(","),
            result.seconds.unwrap_or(0.0),
            cli.out.display()
        );
    }
    Ok(())
}
