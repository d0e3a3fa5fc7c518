//! # envpg-cli
//!
//! The `envpg` tools as a library: [`main`] is the whole program for the environments of a
//! [`Registry`], so a crate with environments of its own gets every tool in one line:
//!
//! ```no_run
//! fn main() -> std::process::ExitCode {
//!     envpg_cli::main_with_launcher(envpg_envs::registry() /* .register::<MyEnv>() */, "my-launch")
//! }
//! ```
//!
//! Subcommands turn raw arguments into validated configurations and call the libraries:
//! `envs` (the registered environments and their parameters), `oracle` (annealed model-based
//! co-design), `evaluate` (exact J of a result file or a design), `instance` (generate or check
//! instance files), `table` (Table I with its figures, for any environment), `plot` (figures
//! from result files), `sweep` (sensitivity studies), `bench` (side-by-side timings).
//!
//! Exit codes: 0 success, 1 the computation failed, 2 bad input (arguments, files, an
//! environment without the model a command needs).

mod args;
mod cmd_bench;
mod cmd_envs;
mod cmd_evaluate;
mod cmd_instance;
mod cmd_oracle;
mod cmd_plot;
mod cmd_sweep;
mod cmd_table;
mod experiment_args;

use std::process::ExitCode;

use clap::{Parser, Subcommand};
use envpg_core::Registry;
use envpg_core::exit::Failure;

/// Tools for envpg: model-based oracle, exact evaluation, instances, experiments and figures.
#[derive(Debug, Parser)]
#[command(name = "envpg", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// The registered environments, their parameters and bundled instances.
    Envs,
    /// Annealed model-based co-design with exact gradients (the paper's oracle).
    Oracle(cmd_oracle::OracleArgs),
    /// Exact J (and J_H) of a result file, or of a design with its optimal policy.
    Evaluate(cmd_evaluate::EvaluateArgs),
    /// Generate or check instance files.
    #[command(subcommand)]
    Instance(cmd_instance::InstanceCmd),
    /// Table I: Algorithm 1 and the oracle for every column and seed, with figures (resumable).
    Table(cmd_table::TableArgs),
    /// Figures (placements, gradient norm, learning curves, trajectories) from result files.
    Plot(cmd_plot::PlotArgs),
    /// Sweep one setting over values × seeds: final J, estimator variance and bias.
    Sweep(cmd_sweep::SweepArgs),
    /// Benchmarks that report ratios measured side by side.
    #[command(subcommand)]
    Bench(cmd_bench::BenchCmd),
}

/// The `envpg` program for the environments of `registry`; `table --workers` and `sweep
/// --workers` run `envpg-launch` from beside this executable.
pub fn main(registry: Registry) -> ExitCode {
    main_with_launcher(registry, "envpg-launch")
}

/// As [`main`], with the launcher binary (beside this executable, or `$ENVPG_LAUNCH`) that
/// `--workers` runs: one built with the same environments.
pub fn main_with_launcher(registry: Registry, launcher: &str) -> ExitCode {
    args::init_tracing();
    match execute(Cli::parse(), registry, launcher) {
        Ok(()) => ExitCode::SUCCESS,
        Err(f) => {
            eprintln!("error: {}", f.message);
            ExitCode::from(f.code)
        }
    }
}

/// Runs the `envpg` program on `args` (the program's name first, as [`std::env::args`]) in
/// this process, returning how it failed instead of exiting: for front ends such as the Python
/// package. Help and version requests print and succeed.
pub fn run_args<I, T>(registry: Registry, launcher: &str, args: I) -> Result<(), Failure>
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    args::init_tracing();
    let cli = match Cli::try_parse_from(args) {
        Ok(cli) => cli,
        Err(e) if !e.use_stderr() => {
            print!("{e}");
            return Ok(());
        }
        Err(e) => return Err(Failure::usage(&e.render().to_string())),
    };
    execute(cli, registry, launcher)
}

fn execute(cli: Cli, registry: Registry, launcher: &str) -> Result<(), Failure> {
    envpg_ac::memory::retain_freed_memory();
    let tools = args::Tools { registry, launcher: launcher.to_owned() };
    let result = match cli.command {
        Command::Envs => cmd_envs::run(&tools),
        Command::Oracle(a) => cmd_oracle::run(a, &tools),
        Command::Evaluate(a) => cmd_evaluate::run(a, &tools),
        Command::Instance(c) => cmd_instance::run(c, &tools),
        Command::Table(a) => cmd_table::run(a, &tools),
        Command::Plot(a) => cmd_plot::run(a, &tools),
        Command::Sweep(a) => cmd_sweep::run(a, &tools),
        Command::Bench(c) => cmd_bench::run(c, &tools),
    };
    result.map_err(|e| args::failure(&e))
}
