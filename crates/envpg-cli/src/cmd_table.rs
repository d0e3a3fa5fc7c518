//! `envpg table`: the paper's Table I with its figures.

use std::path::PathBuf;
use std::sync::Mutex;

use anyhow::Result;
use clap::Args;
use envpg_report::{JobReport, TablePlan, Vary, run_table};
use indicatif::{ProgressBar, ProgressStyle};

use crate::args::{InstanceArgs, Tools};
use crate::experiment_args::{RunnerArgs, SettingsArgs, command_line, machine_line, parse_seeds, parse_vary};

/// The columns of the paper's Table I, the default on its instance.
const PAPER_KAPPAS: [f64; 4] = [1.0, 0.95, 0.9, 0.85];

/// Options of `envpg table`.
#[derive(Debug, Args)]
pub struct TableArgs {
    #[command(flatten)]
    instance: InstanceArgs,
    /// Columns: one parameter of the environment over several values, `KEY=V1,V2,…` (e.g.
    /// `--vary temperature=100,0.01`) [default: one column, the instance as given; on the
    /// paper's instance `uav271`, its Table I: `kappa=1,0.95,0.9,0.85`].
    #[arg(long, value_name = "KEY=V1,V2,…", conflicts_with = "kappas")]
    vary: Option<String>,
    /// Shorthand for `--vary kappa=LIST` (uav, flpo).
    #[arg(long, value_delimiter = ',')]
    kappas: Option<Vec<f64>>,
    /// Seeds: `1..6` or a list.
    #[arg(long, default_value = "1..6")]
    seeds: String,
    #[command(flatten)]
    settings: SettingsArgs,
    #[command(flatten)]
    runner: RunnerArgs,
    /// Restarts of the best-of-restarts oracle.
    #[arg(long, default_value_t = 16)]
    restarts: usize,
    /// Seed of the best-of-restarts oracle.
    #[arg(long, default_value_t = 1)]
    oracle_seed: u64,
    /// A seed "reaches the best basin" when its J is within this relative tolerance of the
    /// best-of-restarts oracle.
    #[arg(long, default_value_t = 0.01)]
    basin_tol: f64,
    /// Moving-average window of the per-iteration figures.
    #[arg(long, default_value_t = 100)]
    window: usize,
    /// Output directory (re-running resumes: finished runs are kept).
    #[arg(long, default_value = "results/table")]
    out: PathBuf,
    /// No progress bar (a line per finished run is still printed).
    #[arg(long)]
    quiet: bool,
}

/// Runs the table.
pub fn run(a: TableArgs, tools: &Tools) -> Result<()> {
    crate::args::check_dir_writable(&a.out)?;
    let env = a.instance.load(&tools.registry)?;
    let config = a.settings.config(&tools.registry, env.name)?;
    let (runner, jobs) = a.runner.runner(&a.out, tools)?;
    let vary = match (&a.vary, &a.kappas) {
        (Some(v), _) => Some(parse_vary(v)?),
        (None, Some(k)) => Some(Vary { key: "kappa".into(), values: k.clone() }),
        (None, None) if a.instance.instance == envpg_envs::BUNDLED_UAV && a.instance.kappa.is_none() => {
            Some(Vary { key: "kappa".into(), values: PAPER_KAPPAS.to_vec() })
        }
        (None, None) => None,
    };
    let plan = TablePlan {
        registry: tools.registry.clone(),
        instance: env.instance.clone(),
        vary,
        seeds: parse_seeds(&a.seeds)?,
        config,
        restarts: a.restarts,
        oracle_seed: a.oracle_seed,
        basin_tol: a.basin_tol,
        jobs,
        window: a.window,
        preamble: vec![command_line(), machine_line()],
    };
    let columns = plan.validate()?;
    let bar = bar(plan.jobs(&columns).len() as u64, a.quiet);
    let bar_ref = Mutex::new(&bar);
    let on_job = |r: &JobReport| {
        let line = match (&r.outcome, r.skipped) {
            (Ok(j), true) => format!("[{}/{}] {}: kept, J = {}", r.done, r.total, r.job, fmt_j(*j)),
            (Ok(j), false) => format!("[{}/{}] {}: J = {} ({:.1} s)", r.done, r.total, r.job, fmt_j(*j), r.seconds),
            (Err(e), _) => format!("[{}/{}] {}: FAILED: {e}", r.done, r.total, r.job),
        };
        let b = bar_ref.lock().unwrap();
        log_line(*b, line);
    };
    let summary = run_table(&plan, &a.out, runner.as_ref(), &on_job);
    bar.finish_and_clear();
    let summary = summary?;
    print!("{}", summary.markdown());
    println!("\nwrote {0}/table.md, {0}/table.csv, figures and runs/ in {0}", a.out.display());
    Ok(())
}

fn fmt_j(j: Option<f64>) -> String {
    j.map_or("n/a (improper policy)".into(), envpg_report::stats::fixed)
}

/// Prints a line above the bar (or plainly when the bar is hidden, e.g. with --quiet or when
/// stderr is not a terminal) and advances it.
pub fn log_line(bar: &ProgressBar, line: String) {
    if bar.is_hidden() {
        println!("{line}");
    } else {
        bar.println(line);
    }
    bar.inc(1);
}

/// A progress bar over jobs (hidden with --quiet or when stderr is not a terminal).
pub fn bar(total: u64, quiet: bool) -> ProgressBar {
    bar_with(total, quiet, "{bar:40} {pos}/{len} runs, {elapsed} elapsed, ~{eta} left")
}

/// [`bar`] drawn with an indicatif `template`.
pub fn bar_with(total: u64, quiet: bool, template: &str) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    let b = ProgressBar::new(total);
    b.set_style(ProgressStyle::with_template(template).unwrap_or_else(|_| ProgressStyle::default_bar()));
    b
}
