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
mod train;

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use anyhow::Result;
use clap::{Parser, Subcommand};
use envpg_core::Registry;
use envpg_core::exit::{self, Failure};
pub use program::{EXIT_ENV, EnvFailed, Program, abort_env};

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
        None => train::run(cli.train, cli.launch, registry),
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
