//! `envpg sweep`: one setting over values × seeds.

use std::path::PathBuf;
use std::sync::Mutex;

use anyhow::Result;
use clap::Args;
use envpg_report::sweep::{SweepRow, markdown};
use envpg_report::{SweepPlan, run_sweep};

use crate::args::{InstanceArgs, Tools, input_err};
use crate::cmd_table::bar;
use crate::experiment_args::{RunnerArgs, SettingsArgs, command_line, machine_line, parse_seeds, split_values};

/// Options of `envpg sweep`.
#[derive(Debug, Args)]
pub struct SweepArgs {
    /// The swept setting: a parameter of the instance's environment (`kappa`, `eta`,
    /// `deviation`, …) or any Algorithm 1 setting (`sigma`, `zeta_lr`, `zeta_estimator`, …).
    #[arg(long)]
    param: String,
    /// Its values, comma-separated (brackets keep lists whole: `[64,64],[128]`).
    #[arg(long)]
    values: String,
    /// Seeds per value: `1..3` or a list.
    #[arg(long, default_value = "1..3")]
    seeds: String,
    #[command(flatten)]
    instance: InstanceArgs,
    #[command(flatten)]
    settings: SettingsArgs,
    #[command(flatten)]
    runner: RunnerArgs,
    /// The estimator study freezes each run after this fraction of its iterations.
    #[arg(long, default_value_t = 0.5)]
    study_at: f64,
    /// Independent batches per estimator in the study.
    #[arg(long, default_value_t = 100)]
    study_samples: usize,
    /// Output directory [default: results/sweep-PARAM].
    #[arg(long)]
    out: Option<PathBuf>,
    /// No progress bar (a line per finished run is still printed).
    #[arg(long)]
    quiet: bool,
}

/// Runs the sweep.
pub fn run(a: SweepArgs, tools: &Tools) -> Result<()> {
    let out = a.out.clone().unwrap_or_else(|| PathBuf::from(format!("results/sweep-{}", a.param)));
    crate::args::check_dir_writable(&out)?;
    let env = a.instance.load(&tools.registry)?;
    let (runner, jobs) = a.runner.runner(&out, tools)?;
    let plan = SweepPlan {
        registry: tools.registry.clone(),
        instance: env.instance.clone(),
        seeds: parse_seeds(&a.seeds)?,
        config: a.settings.config(&tools.registry, env.name)?,
        param: a.param.clone(),
        values: split_values(&a.values),
        study_at: a.study_at,
        study_samples: a.study_samples,
        jobs,
        preamble: vec![command_line(), machine_line()],
    };
    if let Err(e) = plan.validate() {
        return input_err(e.to_string());
    }
    let bar = bar((plan.values.len() * plan.seeds.len()) as u64, a.quiet);
    let bar_ref = Mutex::new(&bar);
    let on_run = |n: usize, total: usize, value: &str, seed: u64, r: &Result<SweepRow, String>| {
        let line = match r {
            Ok(row) => format!(
                "[{n}/{total}] {} = {value}, seed {seed}: J = {}",
                plan.param,
                row.j.map_or("n/a".into(), envpg_report::stats::fixed)
            ),
            Err(e) => format!("[{n}/{total}] {} = {value}, seed {seed}: FAILED: {e}", plan.param),
        };
        let b = bar_ref.lock().unwrap();
        crate::cmd_table::log_line(*b, line);
    };
    let rows = run_sweep(&plan, &out, runner.as_ref(), &on_run);
    bar.finish_and_clear();
    let rows = rows?;
    print!("{}", markdown(&plan, &rows));
    println!("\nwrote {0}/sweep.md, {0}/sweep.csv, {0}/sweep.svg, {0}/sweep.png and runs/", out.display());
    Ok(())
}
