//! # envpg-report
//!
//! The experiments a user reruns to reproduce the paper and to study co-design, and the
//! reports they produce.
//!
//! ## Main types
//! - [`TablePlan`] / [`run_table`]: Table I for any environment with a model — Algorithm 1
//!   (alone, and with the ζ polish) and the oracle (from each seed's own ζ₀, and best of its
//!   restarts) for every column (one environment parameter over several values) and seed, in
//!   parallel, resumable; each run's `envpg.result.v2` file lands in the output directory.
//! - [`Summary`]: the table itself, rendered as `table.md` (the paper's layout) and
//!   `table.csv` (one row per run), computed from result files only.
//! - [`SweepPlan`] / [`run_sweep`]: one setting over a list of values × seeds: final J and the
//!   ζ-gradient estimate's variance and bias against the exact model gradient.
//! - [`figures`]: Figure 1 and friends, rendered with plotters to SVG and PNG with the DejaVu
//!   font shipped in `assets/` (no system font libraries needed).
//!
//! ## Data flow
//! plan → jobs (Algorithm 1 through an [`Alg1Runner`], oracle through `envpg-model`) → result
//! files → [`Summary`] / [`figures`] → `table.md`, `table.csv`, `*.svg`, `*.png`.
//!
//! Every number in a report is read back from the result files, which carry the environment,
//! the full instance with its parameters, ζ, ζ₀ and policy, so anyone can recompute it with
//! `envpg evaluate`.
//!
//! ```
//! use std::sync::atomic::{AtomicUsize, Ordering};
//! use envpg_ac::AcConfig;
//! use envpg_report::{InProcess, TablePlan, run_table};
//!
//! let registry = envpg_envs::registry();
//! let env = registry.load("flpo-n10m4", &[])?;
//! let config = AcConfig { iterations: 30, episodes: 16, explore_episodes: 8, hidden: vec![32], batch: 128,
//!     warmup: 10, eval_every: 10, polish_iterations: 0, ..AcConfig::default() };
//! let plan = TablePlan { registry: registry.clone(), instance: env.instance.clone(), vary: None, seeds: vec![1],
//!     config, restarts: 1, oracle_seed: 1, basin_tol: 1e-3, jobs: 1, window: 5, preamble: vec![] };
//! let (dir, runner) = (tempfile::tempdir()?, InProcess(registry));
//! let summary = run_table(&plan, dir.path(), &runner, &|_| {})?;
//! // One seed, one column: Algorithm 1, the oracle from the same ζ₀, the oracle's best restart.
//! assert_eq!(summary.rows.len(), 3);
//! assert_eq!(summary.csv(), std::fs::read_to_string(dir.path().join("table.csv"))?);
//! assert!(std::fs::read_to_string(dir.path().join("table.md"))?.starts_with("# Table I"));
//! // Run again: every result file is there already, so every job is skipped.
//! let skipped = AtomicUsize::new(0);
//! let count = |job: &envpg_report::JobReport| if job.skipped { skipped.fetch_add(1, Ordering::SeqCst); };
//! run_table(&plan, dir.path(), &runner, &count)?;
//! assert_eq!(skipped.into_inner(), 3);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod error;
pub mod experiment;
pub mod figures;
mod font;
pub mod stats;
pub mod summary;
pub mod sweep;

pub use error::ReportError;
pub use experiment::{Alg1Runner, InProcess, Job, JobReport, TableColumn, TablePlan, Vary, run_table};
pub use summary::{Method, Row, Summary};
pub use sweep::{SweepPlan, SweepRow, run_sweep};
