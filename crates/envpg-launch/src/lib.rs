//! # envpg-launch
//!
//! The launcher of Algorithm 1 as a library: [`main`] is the whole `envpg-launch` program for
//! the environments of a [`Registry`], so a crate with environments of its own gets the same
//! launcher (distributed workers, faults, resume, multi-host) in one line:
//!
//! ```no_run
//! fn main() -> std::process::ExitCode {
//!     envpg_launch::main(envpg_envs::registry() /* .register::<MyEnv>() */)
//! }
//! ```
//!
//! By default it supervises a learner process and `--workers N` rollout-worker processes linked
//! by iceoryx2 shared memory (the same executable in the `learner` / `worker` roles, so the
//! workers know the same environments); `--in-process` runs the same learner and worker code as
//! threads of one process. With the `multi-host` feature, `--listen ENDPOINT` also lets worker
//! hosts join over zenoh (`envpg-launch worker --connect ENDPOINT --workers N` on each of them).
//!
//! Data flow: instance file → [`Registry`] → run description (`run.json`: canonical instance,
//! seed, settings) → learner and worker processes, each building the environment from it →
//! episodes over iceoryx2 → the learner's update → weights back to the workers.
//!
//! Exit codes: 0 success, 1 the run failed, 2 bad input, 130 interrupted.

mod args;
mod bench;
mod in_process;
mod log;
mod metrics;
mod multi_host;
mod passes;
mod program;
mod roles;
mod run_dir;
mod supervise;
pub mod throughput_model;

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use envpg_core::Registry;
use envpg_core::exit::{self, Failure};
use indicatif::{ProgressBar, ProgressStyle};
pub use program::{EXIT_ENV, EnvFailed, Program, abort_env};

use crate::run_dir::RunFile;

/// Train a policy and the environment design together with the EnvPG actor–critic.
#[derive(Debug, Parser)]
#[command(name = "envpg-launch", version, about, args_conflicts_with_subcommands = true)]
struct Cli {
    #[command(subcommand)]
    role: Option<Role>,
    #[command(flatten)]
    train: args::TrainArgs,
    #[command(flatten)]
    launch: LaunchArgs,
}

/// How the run is executed.
#[derive(Debug, clap::Args)]
struct LaunchArgs {
    /// Rollout-worker processes on this host (threads with --in-process); 0 is allowed with
    /// --listen, when every worker is remote.
    #[arg(long, default_value_t = 2)]
    workers: usize,
    /// Also accept rollout workers from other hosts on this zenoh endpoint, e.g.
    /// `tcp/0.0.0.0:7447` (needs the `multi-host` build feature).
    #[arg(long, value_name = "ENDPOINT")]
    listen: Option<String>,
    /// The learner gives up when no episode arrives for this long while work is pending
    /// (seconds); raise it when remote workers may be cut off for a while.
    #[arg(long, default_value_t = 60)]
    stall_timeout_s: u64,
    /// Run learner and workers as threads of this process (no shared memory needed).
    #[arg(long)]
    in_process: bool,
    /// Write the result file (envpg.result.v2) here.
    #[arg(long, default_value = "envpg-result.json")]
    out: PathBuf,
    /// Run directory: run.json, metrics.csv, log.txt, checkpoint.bin and a copy of the result
    /// [default: runs/<run id> under $ENVPG_RUNS_DIR, or under the current directory].
    #[arg(long)]
    run_dir: Option<PathBuf>,
    /// Also write the live metrics as TensorBoard event files in DIR
    /// (`tensorboard --logdir DIR`).
    #[arg(long, value_name = "DIR")]
    tensorboard: Option<PathBuf>,
    /// Checkpoint the learner every this many iterations (needs a run directory to resume from).
    #[arg(long, default_value_t = 0)]
    checkpoint_every: u64,
    /// Continue the run in DIR from its last checkpoint (other options are taken from DIR).
    #[arg(long, value_name = "DIR")]
    resume: Option<PathBuf>,
    /// Passes of Algorithm 1: each pass trains again with a seed of its own, from where
    /// `--pass-start` says; the best pass is the result. Passes are ranked model-free, by
    /// their designs' and greedy policies' sampled cost on common episodes (8× the polish's
    /// episodes per estimate). A way out of a poor basin, at up to N times the run's cost.
    #[arg(long, default_value_t = 1)]
    passes: usize,
    /// Where the passes after the first start: `best` (the design of the best pass so far: for
    /// a run that had not finished improving), `fresh` (the run's `--zeta0`, drawn anew with
    /// the pass's seed: independent restarts), `kick` (the best design so far moved by
    /// Gaussian noise of 2%, 4%, 8%, 2%, … of each coordinate's scale: basin hopping), `warm`
    /// (as `kick`, training on from the best pass's final networks over the last quarter of the
    /// schedule only: a local search with the policy kept) or `portfolio` (the first half of
    /// the passes, rounded up, `fresh`, the rest `warm`). Default `warm`; needs `--passes` 2 or
    /// more.
    #[arg(long, value_enum)]
    pass_start: Option<passes::PassStart>,
    /// Extra real compute per environment step in the workers, in microseconds (benchmarks).
    #[arg(long, default_value_t = 0)]
    emulator_cost_us: u64,
    /// A worker silent for this long is presumed dead and its episodes go to others.
    #[arg(long, default_value_t = 2000)]
    worker_timeout_ms: u64,
    /// Protocol version the workers announce (to test version checks).
    #[arg(long, hide = true, default_value_t = envpg_protocol::PROTOCOL_VERSION)]
    worker_protocol_version: u32,
    /// No progress bar.
    #[arg(long)]
    quiet: bool,
    /// Measure rollout and transport throughput (raw loop, in-process, 1..N worker processes),
    /// training throughput with policy lag 0 and 1 side by side (the learner's share of each
    /// run, no polish) and weight-broadcast latency instead of training; see also
    /// --bench-workers.
    #[arg(long)]
    bench: bool,
    /// Worker-process counts measured by --bench.
    #[arg(long, value_delimiter = ',', default_value = "1,2")]
    bench_workers: Vec<usize>,
    /// Rounds of every --bench measurement (the median is reported).
    #[arg(long, default_value_t = 3)]
    bench_repeats: usize,
    /// Also write the --bench report as JSON here.
    #[arg(long)]
    bench_out: Option<PathBuf>,
}

#[derive(Debug, Subcommand)]
enum Role {
    /// (internal) The learner process of a run.
    #[command(hide = true)]
    Learner {
        /// Run directory.
        #[arg(long)]
        run_dir: PathBuf,
        /// Continue from the checkpoint.
        #[arg(long)]
        resume: bool,
    },
    /// Rollout workers on this host for a learner on another one: `worker --connect
    /// tcp/HOST:PORT --workers N` (needs the `multi-host` build feature). Without --connect this
    /// is the internal worker role of a local run.
    Worker {
        /// The learner host's endpoint (as given to its `--listen`).
        #[arg(long, value_name = "ENDPOINT", conflicts_with_all = ["run_dir", "worker_id"])]
        connect: Option<String>,
        /// Worker processes to run on this host (with --connect).
        #[arg(long, default_value_t = 2)]
        workers: usize,
        /// Give up if no learner answers for this long (seconds, with --connect).
        #[arg(long, default_value_t = 60)]
        join_timeout_s: u64,
        /// Leave when the learner host has been unreachable for this long (seconds, with
        /// --connect; a live learner host answers every second even between iterations).
        #[arg(long, default_value_t = 120)]
        link_timeout_s: u64,
        /// (internal) Run directory.
        #[arg(long, hide = true)]
        run_dir: Option<PathBuf>,
        /// (internal) Worker slot.
        #[arg(long, hide = true)]
        worker_id: Option<u32>,
        /// (internal) Incarnation of the slot.
        #[arg(long, hide = true, default_value_t = 1)]
        incarnation: u64,
        /// (internal) Protocol version to announce.
        #[arg(long, hide = true, default_value_t = envpg_protocol::PROTOCOL_VERSION)]
        protocol_version: u32,
    },
}

/// Marks an error as bad input (exit code 2).
#[derive(Debug)]
pub(crate) struct InputError(pub(crate) String);

impl std::fmt::Display for InputError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for InputError {}

/// The `envpg-launch` program for the environments of `registry`: parses the command line,
/// runs, and maps errors to exit codes (2 for bad input, 1 for a failed run, 130 interrupted).
pub fn main(registry: Registry) -> ExitCode {
    init();
    match execute(Cli::parse(), &registry) {
        Ok(()) => ExitCode::SUCCESS,
        Err(f) => {
            eprintln!("error: {}", f.message);
            ExitCode::from(f.code)
        }
    }
}

/// Runs the `envpg-launch` program on `args` (the program's name first, as
/// [`std::env::args`]) in this process, starting its learner and worker processes with
/// `program`, and returns how it failed instead of exiting: for front ends such as the Python
/// package. Help and version requests print and succeed.
pub fn run_args<I, T>(registry: Registry, program: Program, args: I) -> Result<(), Failure>
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    program::set(program);
    init();
    let cli = match Cli::try_parse_from(args) {
        Ok(cli) => cli,
        Err(e) if !e.use_stderr() => {
            print!("{e}");
            return Ok(());
        }
        Err(e) => return Err(Failure::usage(&e.render().to_string())),
    };
    execute(cli, &registry)
}

/// Logging and memory settings of every process of a run.
fn init() {
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        // zenoh's own warnings (e.g. about scouting while a learner host is not up yet) are
        // noise here: the bridge reports what matters itself.
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("warn,zenoh=error,zenoh_transport=error"));
    {
        use tracing_subscriber::layer::SubscriberExt;
        use tracing_subscriber::util::SubscriberInitExt;
        let _ = tracing_subscriber::registry()
            .with(filter)
            .with(tracing_subscriber::fmt::layer().with_writer(std::io::stderr))
            .with(tracing_subscriber::fmt::layer().with_ansi(false).with_writer(|| log::LogFile))
            .try_init();
    }
    envpg_transport::quiet_iceoryx2_logs();
    envpg_ac::memory::retain_freed_memory();
}

/// Runs one parsed command line; the error is logged here (and printed by the caller).
fn execute(cli: Cli, registry: &Registry) -> Result<(), Failure> {
    let result = match cli.role {
        Some(Role::Learner { run_dir, resume }) => roles::learner(&run_dir, resume, registry),
        Some(Role::Worker {
            connect: Some(endpoint),
            workers,
            join_timeout_s,
            link_timeout_s,
            protocol_version,
            ..
        }) => multi_host::worker_host(
            &multi_host::WorkerHost {
                endpoint,
                workers,
                join_timeout: Duration::from_secs(join_timeout_s),
                link_timeout: Duration::from_secs(link_timeout_s),
                protocol: protocol_version,
            },
            registry,
        ),
        Some(Role::Worker {
            run_dir: Some(run_dir),
            worker_id: Some(worker_id),
            incarnation,
            protocol_version,
            ..
        }) => roles::worker(&run_dir, worker_id, incarnation, protocol_version, registry).map(|_| ()),
        Some(Role::Worker { .. }) => {
            Err(InputError("`envpg-launch worker` needs --connect ENDPOINT (the learner host's --listen)".into())
                .into())
        }
        None => run(cli.train, cli.launch, registry),
    };
    result.map_err(|e| {
        log::to_file(&format!("error: {e:#}"));
        let message = format!("{e:#}");
        if is_interrupt(&e) {
            return Failure { code: exit::INTERRUPTED, message };
        }
        let input = e.chain().any(|c| {
            c.is::<InputError>()
                || c.is::<envpg_core::InstanceError>()
                || c.is::<envpg_core::result::ResultError>()
                || c.is::<envpg_core::ZetaError>()
                || c.is::<envpg_ac::config::ConfigError>()
                || c.is::<envpg_ac::config::PresetError>()
                || c.is::<envpg_protocol::CheckpointError>()
                || c.is::<multi_host::NotBuilt>()
                || multi_host::is_input_error(c)
        });
        Failure { code: if input { exit::INPUT } else { exit::FAILED }, message }
    })
}

/// Whether `e` is an interrupted run (SIGINT/SIGTERM), exit code 130.
fn is_interrupt(e: &anyhow::Error) -> bool {
    e.chain().any(|c| {
        c.is::<supervise::Interrupted>()
            || c.is::<multi_host::HostInterrupted>()
            || matches!(
                c.downcast_ref::<envpg_learner::LearnerError>(),
                Some(envpg_learner::LearnerError::Terminated(_) | envpg_learner::LearnerError::Stopped(_))
            )
    })
}

/// An interrupted run says where it stands and how to continue it (on stderr, before the
/// error itself).
fn with_resume_hint(
    e: anyhow::Error,
    run: &RunFile,
    dir: &std::path::Path,
    resume_dir: &std::path::Path,
) -> anyhow::Error {
    if !is_interrupt(&e) {
        return e;
    }
    let exe = program::get().map_or_else(|_| "envpg-launch".into(), |p| p.display);
    match run.load_checkpoint(dir) {
        Ok(c) => eprintln!(
            "kept: checkpoint at iteration {} of {} in {}\ncontinue the run with: {exe} --resume {}",
            c.k,
            run.spec.config.iterations,
            RunFile::checkpoint_path(dir).display(),
            resume_dir.display()
        ),
        Err(c) => eprintln!("no checkpoint could be kept: {c}"),
    }
    e
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

fn message(alpha: f64, j_h: f64, j: Option<f64>, tps: f64) -> String {
    format!("α={alpha:.3e} J_H≈{j_h:.3} J={} {tps:.0} tr/s", j.map_or("-".into(), |j| format!("{j:.4}")))
}

/// Where run directories go by default: `$ENVPG_RUNS_DIR`, or `runs/` in the current
/// directory (created; one place a user can find and clean).
fn default_runs_dir() -> Result<PathBuf> {
    let dir = match std::env::var_os("ENVPG_RUNS_DIR") {
        Some(d) if !d.is_empty() => PathBuf::from(d),
        _ => std::env::current_dir()?.join("runs"),
    };
    std::fs::create_dir_all(&dir).map_err(|e| {
        InputError(format!(
            "cannot create {} for the run directory: {e} (choose one with --run-dir DIR)",
            dir.display()
        ))
    })?;
    Ok(dir)
}

fn run(train: args::TrainArgs, launch: LaunchArgs, registry: &Registry) -> Result<()> {
    if launch.bench {
        if launch.passes != 1 {
            return Err(
                InputError("--passes does not apply to --bench (it measures throughput, not designs)".into()).into()
            );
        }
        if let Some(p) = &launch.bench_out {
            envpg_core::io::check_writable(p).map_err(|e| InputError(format!("--bench-out: {e}")))?;
        }
        let (env, spec) = train.spec(registry).map_err(|e| InputError(format!("{e:#}")))?;
        let dir = std::env::temp_dir().join(format!("envpg-bench-{}", run_dir::new_run_id()));
        std::fs::create_dir_all(&dir)?;
        let report =
            bench::run(&env, &spec, launch.emulator_cost_us, &launch.bench_workers, launch.bench_repeats, &dir);
        let _ = std::fs::remove_dir_all(&dir);
        let report = report?;
        bench::print(&report);
        if let Some(p) = &launch.bench_out {
            envpg_core::io::write_atomic(p, serde_json::to_string_pretty(&report)?.as_bytes())?;
        }
        return Ok(());
    }
    let (dir, run, resume) = match &launch.resume {
        Some(dir) => {
            let run = RunFile::load(dir).map_err(|e| InputError(format!("--resume {}: {e:#}", dir.display())))?;
            envpg_core::io::check_writable(&run.out)
                .map_err(|e| InputError(format!("--resume {}: the run's result file: {e}", dir.display())))?;
            if run.passes > 1 {
                // Each pass has a directory of its own; passes::run finds where to continue.
                passes::check_resumable(&run, dir)?;
                (dir.clone(), run, None)
            } else {
                // A missing, corrupt or foreign checkpoint is found here, before any process starts.
                let checkpoint =
                    run.load_checkpoint(dir).map_err(|e| InputError(format!("--resume {}: {e}", dir.display())))?;
                (dir.clone(), run, Some(checkpoint))
            }
        }
        None => {
            // Everything that goes wrong while turning arguments into a run is the user's input.
            let (_, spec) = train.spec(registry).map_err(|e| InputError(format!("{e:#}")))?;
            // Outputs next, before any work: a run that cannot keep its result must not start.
            envpg_core::io::check_writable(&launch.out).map_err(|e| InputError(format!("--out: {e}")))?;
            if let Some(d) = &launch.run_dir {
                envpg_core::io::create_private_dir(d)
                    .and_then(|()| envpg_core::io::check_dir_writable(d))
                    .map_err(|e| InputError(format!("--run-dir {}: {e}", d.display())))?;
            }
            if let Some(d) = &launch.tensorboard {
                std::fs::create_dir_all(d)
                    .map_err(|e| e.to_string())
                    .and_then(|()| envpg_core::io::check_dir_writable(d).map_err(|e| e.to_string()))
                    .map_err(|e| InputError(format!("--tensorboard {}: {e}", d.display())))?;
            }
            if launch.workers == 0 && (launch.in_process || launch.listen.is_none()) {
                return Err(InputError("--workers must be at least 1 (0 only with --listen)".into()).into());
            }
            if let Some(endpoint) = &launch.listen {
                if launch.in_process {
                    return Err(InputError("--listen needs the distributed mode, not --in-process".into()).into());
                }
                multi_host::check_listen(endpoint)?;
            }
            if launch.passes == 0 {
                return Err(InputError("--passes must be at least 1".into()).into());
            }
            if launch.passes == 1 && launch.pass_start.is_some() {
                return Err(InputError(
                    "--pass-start applies to the passes after the first: give --passes 2 or more".into(),
                )
                .into());
            }
            if launch.stall_timeout_s == 0 {
                return Err(InputError("--stall-timeout-s must be at least 1".into()).into());
            }
            let run_id = run_dir::new_run_id();
            let dir = match &launch.run_dir {
                Some(d) => d.clone(),
                None => default_runs_dir()?.join(&run_id),
            };
            // Owner only: the run directory holds the run's description and checkpoints.
            envpg_core::io::create_private_dir(&dir).map_err(|e| {
                InputError(format!(
                    "cannot create the run directory {}: {e} (choose one with --run-dir DIR)",
                    dir.display()
                ))
            })?;
            let absolute = |p: &PathBuf| -> Result<PathBuf> {
                Ok(if p.is_absolute() { p.clone() } else { std::env::current_dir()?.join(p) })
            };
            let out = absolute(&launch.out)?;
            let tensorboard = launch.tensorboard.as_ref().map(absolute).transpose()?;
            let run = RunFile {
                run_id,
                spec,
                out,
                workers: launch.workers,
                checkpoint_every: launch.checkpoint_every,
                emulator_cost_us: launch.emulator_cost_us,
                worker_timeout_ms: launch.worker_timeout_ms,
                stall_timeout_s: launch.stall_timeout_s,
                listen: launch.listen.clone(),
                tensorboard,
                passes: launch.passes,
                pass_start: launch.pass_start.unwrap_or_default(),
            };
            run.save(&dir)?;
            (dir, run, None)
        }
    };
    log::keep_in(&dir);
    if !launch.quiet {
        eprintln!("run directory: {}", dir.display());
    }
    if run.passes > 1 {
        return passes::run(&run, &dir, launch.resume.is_some(), &launch, registry);
    }
    let j = train_pass(&run, &dir, resume, &launch, registry, &Pass::only(&dir))?;
    if !launch.quiet {
        println!(
            "J = {}  → {}  (run directory {})",
            j.map_or("inf".into(), |j| format!("{j:.6}")),
            run.out.display(),
            dir.display()
        );
    }
    Ok(())
}

/// Which pass of a run [`train_pass`] trains, for its progress bar and its resume hint.
pub(crate) struct Pass<'a> {
    /// "pass 2/3 " (empty for a one-pass run).
    label: String,
    /// The directory `--resume` takes to continue the run.
    resume_dir: &'a std::path::Path,
}

impl<'a> Pass<'a> {
    fn only(dir: &'a std::path::Path) -> Self {
        Self { label: String::new(), resume_dir: dir }
    }
}

/// Trains the run described by `run` in `dir` (from `resume`'s checkpoint, if given) with
/// learner and workers as processes or threads, streaming its progress to the bar and the live
/// metrics; the result is written to `run.out` and `dir`. Returns the exact J, when the
/// environment has a model.
fn train_pass(
    run: &RunFile,
    dir: &std::path::Path,
    resume: Option<envpg_protocol::Checkpoint>,
    launch: &LaunchArgs,
    registry: &Registry,
    pass: &Pass<'_>,
) -> Result<Option<f64>> {
    let mut live = metrics::Metrics::open(dir, run.tensorboard.as_deref(), resume.as_ref().map(|c| c.k))
        .map_err(|e| InputError(format!("live metrics: {e:#}")))?;
    let bar = progress_bar(run.spec.config.iterations as u64, launch.quiet);
    let label = &pass.label;
    let mut train = || -> Result<Option<f64>> {
        Ok(if launch.in_process {
            let checkpoint = Some(run.checkpoint_policy(dir));
            let env = run.spec.load(registry).map_err(|e| InputError(format!("{e:#}")))?;
            let (result, _) = in_process::run(run, &env, checkpoint, resume.clone(), |p| {
                bar.set_position(p.k + 1);
                bar.set_message(format!("{label}{}", message(p.alpha, p.j_h_estimate, p.j_exact, p.transitions_per_s)));
                live.record(&metrics::ProgressLine::from(p));
                true
            })?;
            run_dir::save_result(&result, &run.out, dir)?;
            result.j
        } else {
            let l = supervise::Launch {
                dir: dir.to_path_buf(),
                // The learner process reads (and checks) the checkpoint again itself.
                resume: resume.is_some(),
                worker_protocol: launch.worker_protocol_version,
                max_restarts: 20,
            };
            let outcome = supervise::supervise(&l, |v| {
                if let Ok(p) = serde_json::from_value::<metrics::ProgressLine>(v.clone()) {
                    bar.set_position(p.k + 1);
                    bar.set_message(format!("{label}{}", message(p.alpha, p.j_h, p.j, p.tps)));
                    live.record(&p);
                }
            })?;
            if let Some(bridge) = outcome.bridge {
                // The learner wrote the result; add what crossed hosts, for the record.
                let mut result = envpg_core::ResultFile::load(&run.out)
                    .with_context(|| format!("reading {} to add the bridge's traffic", run.out.display()))?;
                let details = result.details.get_or_insert_with(|| serde_json::json!({}));
                if let Some(d) = details.as_object_mut() {
                    d.insert("bridge".into(), bridge);
                }
                run_dir::save_result(&result, &run.out, dir)?;
            }
            outcome.done.as_ref().and_then(|d| d.get("J")).and_then(|j| j.as_f64())
        })
    };
    let j = train().map_err(|e| {
        bar.abandon();
        with_resume_hint(e, run, dir, pass.resume_dir)
    })?;
    bar.finish_and_clear();
    Ok(j)
}
