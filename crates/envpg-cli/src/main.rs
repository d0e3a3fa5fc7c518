//! `envpg`: the tools binary.
//!
//! Subcommands turn raw arguments into validated configurations and call the libraries:
//! `oracle` (annealed model-based co-design), `evaluate` (exact J of a result file or a
//! design), `instance` (generate or check instance files), `table` (the paper's Table I with
//! its figures), `plot` (figures from result files), `sweep` (sensitivity studies), `bench`
//! (side-by-side timings).
//!
//! Exit codes: 0 success, 1 the computation failed, 2 bad input (arguments, files).

mod args;
mod cmd_bench;
mod cmd_evaluate;
mod cmd_instance;
mod cmd_oracle;
mod cmd_plot;
mod cmd_sweep;
mod cmd_table;
mod experiment_args;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// Tools for envpg: model-based oracle, exact evaluation, instances, experiments and figures.
#[derive(Debug, Parser)]
#[command(name = "envpg", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Annealed model-based co-design with exact gradients (the paper's oracle).
    Oracle(cmd_oracle::OracleArgs),
    /// Exact J (and J_H) of a result file, or of a design with its optimal policy.
    Evaluate(cmd_evaluate::EvaluateArgs),
    /// Generate or check instance files.
    #[command(subcommand)]
    Instance(cmd_instance::InstanceCmd),
    /// Table I: Algorithm 1 and the oracle for every κ and seed, with figures (resumable).
    Table(cmd_table::TableArgs),
    /// Figures (placements, gradient norm, learning curves, trajectories) from result files.
    Plot(cmd_plot::PlotArgs),
    /// Sweep one setting over values × seeds: final J, estimator variance and bias.
    Sweep(cmd_sweep::SweepArgs),
    /// Benchmarks that report ratios measured side by side.
    #[command(subcommand)]
    Bench(cmd_bench::BenchCmd),
}

fn main() -> ExitCode {
    args::init_tracing();
    envpg_ac::memory::retain_freed_memory();
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Oracle(a) => cmd_oracle::run(a),
        Command::Evaluate(a) => cmd_evaluate::run(a),
        Command::Instance(c) => cmd_instance::run(c),
        Command::Table(a) => cmd_table::run(a),
        Command::Plot(a) => cmd_plot::run(a),
        Command::Sweep(a) => cmd_sweep::run(a),
        Command::Bench(c) => cmd_bench::run(c),
    };
    args::exit_code(result)
}
