//! `envpg oracle`.

use anyhow::{Context, Result};
use clap::Args;
use envpg_model::GradientKind;
use envpg_model::oracle::{Finished, OracleConfig, RestartKind, Strategy, run_oracle_with};
use indicatif::ProgressBar;

use crate::args::{InstanceArgs, Tools, input_err, parse_init, positive};
use crate::cmd_table::bar_with;

/// Options of `envpg oracle`. Unset temperatures default to values scaled to the environment
/// (hot start at 10× its cost scale; for the UAV network, its squared extent).
#[derive(Debug, Args)]
pub struct OracleArgs {
    #[command(flatten)]
    instance: InstanceArgs,
    /// Number of restarts; the best is kept. ζ₀ is the environment's random design (for uav
    /// uniform over the users' bounding box, otherwise over the design bounds), except for the
    /// portfolio's warm restarts: its clustered design where it has one (uav: the users'
    /// k-means centres).
    #[arg(long, default_value_t = 16)]
    restarts: usize,
    /// Seed of ζ₀ draws and annealing noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Initial design of the first restart: d comma-separated numbers inside the design
    /// bounds, or a result file on the same instance (its `zeta0`, e.g. the start of a
    /// model-free run).
    #[arg(long, value_name = "ZETA|RESULT.json")]
    init: Option<String>,
    /// How ∇ζ J_H is computed: exactly from the model, or by central differences.
    #[arg(long, value_enum, default_value = "exact")]
    gradient: GradientArg,
    /// Kinds of restart: `anneal` (deterministic annealing from hot; ζ₀ is forgotten), `warm`
    /// (from ζ₀ at --warm-alpha0, SSP form where it exists), `mixed` (one anneal, the rest
    /// warm), `portfolio` (one anneal at --cooling, then warm restarts and faster anneals at
    /// cooling², cooling³, cooling⁴ alternate; warm ones start from clustered designs where
    /// the environment has them), `auto` (portfolio when the model is
    /// deterministic, mixed otherwise). With --init, restart 0 is warm.
    #[arg(long, value_enum, default_value = "auto")]
    strategy: StrategyArg,
    /// Starting temperature of anneal restarts [default: 10 × the environment's cost scale].
    #[arg(long)]
    alpha0: Option<f64>,
    /// Starting temperature of warm restarts [default: the environment's hint; 0.5 for uav].
    #[arg(long)]
    warm_alpha0: Option<f64>,
    /// Last positive temperature.
    #[arg(long)]
    alpha_min: Option<f64>,
    /// Temperature factor per level, in (0, 1).
    #[arg(long)]
    cooling: Option<f64>,
    /// Levels hotter than this use the finite-horizon form (SSP below) [default: 1% of the cost scale].
    #[arg(long)]
    alpha_switch: Option<f64>,
    /// Horizon of the finite-horizon form [default: the environment's; M+1 for uav and flpo,
    /// every simple route through the M relays or facilities].
    #[arg(long)]
    horizon: Option<usize>,
    /// L-BFGS iterations per temperature level.
    #[arg(long)]
    iters_per_level: Option<usize>,
    /// Levels hotter than the last positive temperature stop once an L-BFGS step is shorter
    /// than this, in units of the instance's length scale (they only track the minimiser the
    /// next level starts from); the last level and the polish converge fully. 0: every level
    /// converges fully [default: 1e-4].
    #[arg(long)]
    tracking_tol: Option<f64>,
    /// Symmetry-breaking noise added to ζ at each finite-horizon level: its standard deviation
    /// in units of the instance's length scale [default: 0.001].
    #[arg(long)]
    perturb: Option<f64>,
    /// Kicks after the restarts (basin hopping): warm restarts from the best design so far,
    /// moved by Gaussian noise, two per round, each round from the best design after the one
    /// before [default: 6 with the portfolio, 0 otherwise].
    #[arg(long)]
    kicks: Option<usize>,
    /// Standard deviation of the smallest kick, in units of the instance's length scale;
    /// kicks cycle through 1×, 2× and 4× this.
    #[arg(long, default_value_t = 0.01)]
    kick_scale: f64,
    /// Relocation kicks after the kicks: colder warm restarts from the best design so far with
    /// one design element (a UAV, a facility) moved to serve a costly hop, two per round
    /// [default: 4 with the portfolio on an environment with design elements, 0 otherwise].
    #[arg(long)]
    relocations: Option<usize>,
    /// Starting temperature of relocation kicks [default: a tenth of --warm-alpha0].
    #[arg(long)]
    relocation_alpha0: Option<f64>,
    /// Threads for restarts, at least 1 [default: available cores].
    #[arg(long)]
    threads: Option<usize>,
    /// Write the result file (envpg.result.v2) here.
    #[arg(long)]
    out: Option<std::path::PathBuf>,
    /// No progress bar (it is shown on stderr only when that is a terminal).
    #[arg(long)]
    quiet: bool,
    /// Instead of the bar, a line on stderr as each restart or kick ends (`envpg oracle: 3/26
    /// ended, restart 5: J = …, best J = …`), for log files and programs that run the oracle.
    #[arg(long, conflicts_with = "quiet")]
    progress_lines: bool,
}

#[derive(Debug, Clone, Copy, clap::ValueEnum)]
enum StrategyArg {
    Auto,
    Anneal,
    Warm,
    Mixed,
    Portfolio,
}

#[derive(Debug, Clone, Copy, clap::ValueEnum)]
enum GradientArg {
    Exact,
    Fd,
}

/// Runs the oracle and prints a summary.
pub fn run(a: OracleArgs, tools: &Tools) -> Result<()> {
    let env = a.instance.load(&tools.registry)?;
    let net = env.model()?;
    let mut cfg = OracleConfig::for_env(net);
    cfg.restarts = a.restarts;
    cfg.seed = a.seed;
    cfg.gradient = match a.gradient {
        GradientArg::Exact => GradientKind::Exact,
        GradientArg::Fd => GradientKind::Fd,
    };
    cfg.strategy = match a.strategy {
        StrategyArg::Auto => Strategy::Auto,
        StrategyArg::Anneal => Strategy::Anneal,
        StrategyArg::Warm => Strategy::Warm,
        StrategyArg::Mixed => Strategy::Mixed,
        StrategyArg::Portfolio => Strategy::Portfolio,
    };
    if let Some(x) = a.alpha0 {
        cfg.alpha0 = positive("--alpha0", x)?;
    }
    if let Some(x) = a.warm_alpha0 {
        cfg.warm_alpha0 = positive("--warm-alpha0", x)?;
    }
    if let Some(x) = a.alpha_min {
        cfg.alpha_min = positive("--alpha-min", x)?;
    }
    if let Some(x) = a.cooling {
        cfg.cooling = x;
    }
    if let Some(x) = a.alpha_switch {
        cfg.alpha_switch = x;
    }
    if let Some(h) = a.horizon {
        cfg.horizon = h;
    }
    if let Some(n) = a.iters_per_level {
        cfg.iters_per_level = n;
    }
    if let Some(x) = a.tracking_tol {
        cfg.tracking_tol = x;
    }
    if let Some(x) = a.perturb {
        cfg.perturb = x;
    }
    cfg.kicks = a.kicks;
    cfg.kick_scale = a.kick_scale;
    cfg.relocations = a.relocations;
    if let Some(x) = a.relocation_alpha0 {
        cfg.relocation_alpha0 = Some(positive("--relocation-alpha0", x)?);
    }
    if let Some(t) = a.threads {
        cfg.threads = t;
    }
    if let Some(init) = &a.init {
        cfg.init = Some(parse_init(init, &env)?);
    }
    if let Err(e) = cfg.validate(net) {
        return input_err(e.to_string());
    }
    if let Some(path) = &a.out {
        crate::args::check_writable(path)?;
    }
    let bar = progress_bar(cfg.restarts, a.quiet || a.progress_lines);
    // The best J so far and the number of restarts ended, updated together.
    let seen = std::sync::Mutex::new((f64::INFINITY, 0usize));
    let out = run_oracle_with(net, &cfg, &|f: Finished<'_>| {
        let mut seen = seen.lock().unwrap_or_else(|e| e.into_inner());
        seen.0 = seen.0.min(f.restart.j);
        seen.1 += 1;
        if a.progress_lines {
            let r = f.restart;
            let kick = match (r.kind, r.from) {
                (RestartKind::Relocation, Some(from)) => format!(" (relocation from {from})"),
                (_, Some(from)) => format!(" (kick from {from})"),
                (_, None) => String::new(),
            };
            eprintln!(
                "envpg oracle: {}/{} ended, restart {}{kick}: J = {:.6}, best J = {:.6}, {:.2}s",
                seen.1, f.total, r.index, r.j, seen.0, r.seconds
            );
        }
        bar.set_length(f.total as u64);
        bar.set_message(format!("best J {:.6}", seen.0));
        bar.inc(1);
    });
    bar.finish_and_clear();
    let out = out.context("oracle failed")?;
    let best = &out.restarts[out.best];
    println!(
        "oracle  instance={} env={} {} restarts={} kicks={} relocations={} seed={}",
        env.title,
        env.name,
        env.params_text(),
        cfg.restarts,
        out.restarts.iter().filter(|r| r.kind == RestartKind::Kick).count(),
        out.restarts.iter().filter(|r| r.kind == RestartKind::Relocation).count(),
        cfg.seed
    );
    for r in &out.restarts {
        let from = r.from.map(|f| format!(" from {f}")).unwrap_or_default();
        println!(
            "  restart {:>2} ({:?}{from}): J = {:.6}  J_H = {:.6}  ssp_fallbacks = {}  {:.2}s",
            r.index, r.kind, r.j, r.j_h, r.ssp_fallbacks, r.seconds
        );
    }
    println!(
        "best J = {:.6} (restart {}), reached by {:.0}% of the independent restarts (within {:.0e}), {:.2}s",
        best.j,
        out.best,
        100.0 * out.fraction_best,
        cfg.basin_tol,
        out.seconds
    );
    println!("zeta = {}", fmt_vec(&best.zeta));
    if let Some(path) = &a.out {
        let file = out.to_result(&env, &cfg)?;
        file.save(path).with_context(|| format!("writing {}", path.display()))?;
        println!("wrote {}", path.display());
    }
    Ok(())
}

/// Restarts and kicks done of all (the kicks count as restarts), on stderr (hidden with --quiet
/// or when stderr is not a terminal).
fn progress_bar(restarts: usize, quiet: bool) -> ProgressBar {
    // The kicks are added to the total once the first restart says how many the run has.
    let bar = bar_with(restarts as u64, quiet, "{bar:30} {pos}/{len} restarts, {elapsed}  {msg}");
    if !bar.is_hidden() {
        bar.enable_steady_tick(std::time::Duration::from_millis(500));
    }
    bar
}

/// Formats a vector compactly.
pub fn fmt_vec(v: &[f64]) -> String {
    v.iter().map(|x| format!("{x:.4}")).collect::<Vec<_>>().join(",")
}
