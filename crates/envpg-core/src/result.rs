//! The `envpg.result.v1` result file.
//!
//! Every command that produces a design writes one. It carries everything needed to recompute
//! its objective independently: the full instance, κ, η, ζ, ζ₀ and the policy whose exact J is
//! reported. Method-specific detail (restarts, history, configuration) lives in optional fields.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::instance::Instance;

/// The schema tag.
pub const SCHEMA: &str = "envpg.result.v1";

/// One result file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ResultFile {
    /// Always [`SCHEMA`].
    pub schema: String,
    /// `"oracle"`, `"envpg-ac"`, `"evaluate"`, …
    pub method: String,
    /// The full instance.
    pub instance: Instance,
    /// Target probability κ.
    pub kappa: f64,
    /// Off-target concentration η.
    pub eta: f64,
    /// Run seed.
    pub seed: u64,
    /// Final design ζ (2M numbers).
    pub zeta: Vec<f64>,
    /// Initial design ζ₀ of the run (of the best restart for multi-start methods).
    pub zeta0: Vec<f64>,
    /// One row per non-terminal state (users, then UAVs) over the M+1 global actions
    /// (UAV 0..M−1, then destination); zeros for invalid actions. `J` is this policy's value.
    pub policy: Vec<Vec<f64>>,
    /// Exact objective of (`zeta`, `policy`); `null` when the policy never reaches the
    /// destination from some state (see `j_error`).
    #[serde(rename = "J")]
    pub j: Option<f64>,
    /// Why `J` is missing, if it is.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub j_error: Option<String>,
    /// Entropy-regularised objective of the final soft policy at the final temperature.
    #[serde(rename = "J_H", default, skip_serializing_if = "Option::is_none")]
    pub j_h: Option<f64>,
    /// Final temperature α.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub alpha_final: Option<f64>,
    /// Final soft (stochastic) policy, same layout as `policy`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub policy_soft: Option<Vec<Vec<f64>>>,
    /// Wall-clock seconds of the run.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seconds: Option<f64>,
    /// The method's configuration, as given.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub config: Option<serde_json::Value>,
    /// Method-specific details (restarts, counters, …).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub details: Option<serde_json::Value>,
    /// Per-iteration history of iterative methods.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub history: Option<Vec<HistoryRow>>,
}

/// One row of a run's history.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HistoryRow {
    /// Iteration (or annealing level) index.
    pub k: u64,
    /// Temperature α at this iteration.
    pub alpha: f64,
    /// The method's own estimate of J_H (sampled), if any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub j_h_estimate: Option<f64>,
    /// Norm of the ζ-gradient (estimate) used at this iteration.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub grad_norm: Option<f64>,
    /// ζ_k.
    pub zeta: Vec<f64>,
    /// Exact J of (ζ_k, greedy policy), evaluated for reporting only, every few iterations.
    #[serde(rename = "J_exact", default, skip_serializing_if = "Option::is_none")]
    pub j_exact: Option<f64>,
    /// Extra per-iteration statistics (losses, lengths, …).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stats: Option<serde_json::Value>,
}

/// Why a result file could not be read.
#[derive(Debug, thiserror::Error)]
pub enum ResultError {
    /// I/O failure.
    #[error("cannot read result file {path}: {err}")]
    Io {
        /// The file.
        path: std::path::PathBuf,
        /// The I/O error (kept out of the error chain: it is already in the message).
        err: std::io::Error,
    },
    /// Not a result file of this schema.
    #[error("malformed result file {path}: {reason}")]
    Malformed {
        /// The file.
        path: std::path::PathBuf,
        /// What is wrong.
        reason: String,
    },
}

impl ResultFile {
    /// Reads and checks a result file (schema tag, instance validity, sizes).
    pub fn load(path: impl AsRef<Path>) -> Result<Self, ResultError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|err| ResultError::Io { path: path.to_owned(), err })?;
        let malformed = |reason: String| ResultError::Malformed { path: path.to_owned(), reason };
        let r: ResultFile = serde_json::from_str(&text).map_err(|e| malformed(e.to_string()))?;
        if r.schema != SCHEMA {
            return Err(malformed(format!("schema is {:?}, expected {SCHEMA:?}", r.schema)));
        }
        r.instance.validate_as(path).map_err(|e| malformed(e.to_string()))?;
        let d = r.instance.zeta_dim();
        if r.zeta.len() != d || r.zeta0.len() != d {
            return Err(malformed(format!("zeta/zeta0 must have {d} entries")));
        }
        let rows = r.instance.n_users() + r.instance.n_uav;
        if r.policy.len() != rows || r.policy.iter().any(|row| row.len() != r.instance.n_uav + 1) {
            return Err(malformed(format!("policy must have {rows} rows of {} entries", r.instance.n_uav + 1)));
        }
        Ok(r)
    }

    /// Writes the file atomically as pretty JSON.
    pub fn save(&self, path: impl AsRef<Path>) -> std::io::Result<()> {
        let text = serde_json::to_string_pretty(self).map_err(std::io::Error::other)?;
        crate::io::write_atomic(path, text.as_bytes())
    }
}
