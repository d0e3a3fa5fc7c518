//! `envpg`: the tools binary.
//!
//! Subcommands turn raw arguments into validated configurations and call the libraries:
//! `oracle` (annealed model-based co-design), `evaluate` (exact J of a result file or a
//! design), `instance` (generate or check instance files), `bench` (side-by-side timings).
//!
//! Exit codes: 0 success, 1 the computation failed, 2 bad input (arguments, files).

mod args;
mod cmd_bench;
mod cmd_evaluate;
mod cmd_instance;
mod cmd_oracle;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// Tools for envpg: model-based oracle, exact evaluation, instances.
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
    /// Benchmarks that report ratios measured side by side.
    #[command(subcommand)]
    Bench(cmd_bench::BenchCmd),
}

fn main() -> ExitCode {
    args::init_tracing();
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Oracle(a) => cmd_oracle::run(a),
        Command::Evaluate(a) => cmd_evaluate::run(a),
        Command::Instance(c) => cmd_instance::run(c),
        Command::Bench(c) => cmd_bench::run(c),
    };
    args::exit_code(result)
}
