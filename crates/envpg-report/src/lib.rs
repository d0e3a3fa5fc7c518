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
