//! Live metrics of a run: each iteration's progress, from the learner thread (in-process) or
//! the learner process's progress lines (distributed), goes to `metrics.csv` in the run
//! directory and, with `--tensorboard DIR`, to TensorBoard event files there.

use std::path::Path;

use envpg_ac::trainer::Progress;
use envpg_metrics::MetricsWriter;
use serde::{Deserialize, Serialize};

/// The columns of `metrics.csv` after `k` (also the TensorBoard tags), in order.
pub const COLUMNS: &[&str] = &[
    "alpha",
    "J_H_estimate",
    "J_estimate",
    "zeta_grad_norm",
    "critic_loss",
    "actor_loss",
    "J_exact",
    "transitions_per_s",
    "seconds",
];

/// One iteration's progress as the learner process prints it (a JSON line on stdout) and the
/// launcher reads it.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ProgressLine {
    /// Iteration just completed.
    pub k: u64,
    /// Total iterations.
    pub total: u64,
    /// α.
    pub alpha: f64,
    /// J_H estimate.
    pub j_h: f64,
    /// Transitions per second.
    pub tps: f64,
    /// Latest exact J.
    pub j: Option<f64>,
    /// Exact J computed at this iteration.
    #[serde(default)]
    pub j_now: Option<f64>,
    /// Sampled J estimate.
    #[serde(default)]
    pub j_estimate: f64,
    /// ‖ζ-gradient estimate‖.
    #[serde(default)]
    pub grad_norm: Option<f64>,
    /// Critic TD loss.
    #[serde(default)]
    pub critic_loss: f64,
    /// Actor loss.
    #[serde(default)]
    pub actor_loss: f64,
    /// Seconds of the run so far.
    #[serde(default)]
    pub seconds: f64,
}

impl From<&Progress> for ProgressLine {
    fn from(p: &Progress) -> Self {
        Self {
            k: p.k,
            total: p.total,
            alpha: p.alpha,
            j_h: p.j_h_estimate,
            tps: p.transitions_per_s,
            j: p.j_exact,
            j_now: p.j_exact_now,
            j_estimate: p.j_estimate,
            grad_norm: p.grad_norm,
            critic_loss: p.critic_loss,
            actor_loss: p.actor_loss,
            seconds: p.seconds,
        }
    }
}

impl ProgressLine {
    /// The values of [`COLUMNS`].
    fn values(&self) -> [Option<f64>; 9] {
        [
            Some(self.alpha),
            Some(self.j_h),
            Some(self.j_estimate),
            self.grad_norm,
            Some(self.critic_loss),
            Some(self.actor_loss),
            self.j_now,
            Some(self.tps),
            Some(self.seconds),
        ]
    }
}

/// `DIR/metrics.csv`.
pub fn csv_path(dir: &Path) -> std::path::PathBuf {
    dir.join("metrics.csv")
}

/// The run's metrics sink. A write that fails mid-run (disk full) is reported once and the
/// run goes on: metrics are for watching; the result file is what is kept.
#[derive(Debug)]
pub struct Metrics {
    writer: Option<MetricsWriter>,
}

impl Metrics {
    /// Opens `DIR/metrics.csv` (and TensorBoard files in `tensorboard`); a resumed run passes
    /// the first iteration it will record.
    pub fn open(dir: &Path, tensorboard: Option<&Path>, resume_from: Option<u64>) -> anyhow::Result<Self> {
        Ok(Self { writer: Some(MetricsWriter::create(&csv_path(dir), tensorboard, COLUMNS, resume_from)?) })
    }

    /// Records one iteration.
    pub fn record(&mut self, p: &ProgressLine) {
        if let Some(w) = &mut self.writer
            && let Err(e) = w.record(p.k, &p.values())
        {
            tracing::warn!("live metrics stopped: {e} (the run goes on; its result file keeps the history)");
            self.writer = None;
        }
    }
}
