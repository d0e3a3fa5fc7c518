//! The `envpg.result.v2` result file.
//!
//! Every command that produces a design writes one. It carries everything needed to recompute
//! its objective independently: the environment's name, the full instance with every parameter
//! actually used, ζ, ζ₀ and the policy whose exact J is reported — rows are the environment's
//! non-terminal states in its documented order, columns its global actions. Method-specific
//! detail (restarts, history, configuration) lives in optional fields.
//!
//! `envpg.result.v1` files (UAV only, κ and η beside the instance) still load: they are read as
//! the v2 file they describe.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use serde_json::Value;

use crate::registry::{LoadedEnv, Registry};

/// The schema tag written.
pub const SCHEMA: &str = "envpg.result.v2";
/// The previous schema, still read.
pub const SCHEMA_V1: &str = "envpg.result.v1";

/// One result file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ResultFile {
    /// Always [`SCHEMA`] once loaded.
    pub schema: String,
    /// `"oracle"`, `"envpg-ac"`, …
    pub method: String,
    /// The environment's registered name.
    pub env: String,
    /// The full instance in canonical form (its fields, `env`, `name`, every parameter).
    pub instance: Value,
    /// Run seed.
    pub seed: u64,
    /// Final design ζ.
    pub zeta: Vec<f64>,
    /// Initial design ζ₀ of the run (of the best restart for multi-start methods).
    pub zeta0: Vec<f64>,
    /// One row per non-terminal state (state order) over the global actions; zeros for
    /// invalid actions. `J` is this policy's value.
    pub policy: Vec<Vec<f64>>,
    /// Exact objective of (`zeta`, `policy`); `null` when the policy never terminates from some
    /// state, or when the environment has no model (see `j_error`).
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
    pub config: Option<Value>,
    /// Method-specific details (restarts, counters, …).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub details: Option<Value>,
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
    pub stats: Option<Value>,
}

/// Why a result file could not be read.
#[derive(Debug, thiserror::Error)]
pub enum ResultError {
    /// I/O failure.
    #[error("cannot read result file {path}: {err}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error (kept out of the error chain: it is already in the message).
        err: std::io::Error,
    },
    /// Not a result file of a known schema, or one that does not fit its environment.
    #[error("malformed result file {path}: {reason}")]
    Malformed {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
}

impl ResultFile {
    /// Reads a result file (either schema) and checks its structure. Its fit to the
    /// environment is checked by [`ResultFile::load_env`].
    pub fn load(path: impl AsRef<Path>) -> Result<Self, ResultError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|err| ResultError::Io { path: path.to_owned(), err })?;
        Self::from_json_str(&text, path)
    }

    /// As [`ResultFile::load`], from text (`path` names it in errors).
    pub fn from_json_str(text: &str, path: impl AsRef<Path>) -> Result<Self, ResultError> {
        let path = path.as_ref();
        let malformed = |reason: String| ResultError::Malformed { path: path.to_owned(), reason };
        let mut v: Value = serde_json::from_str(text).map_err(|e| malformed(e.to_string()))?;
        match v.get("schema").and_then(Value::as_str) {
            Some(SCHEMA) => {}
            Some(SCHEMA_V1) => upgrade_v1(&mut v).map_err(malformed)?,
            other => return Err(malformed(format!("schema is {other:?}, expected {SCHEMA:?} or {SCHEMA_V1:?}"))),
        }
        let r: ResultFile = serde_json::from_value(v).map_err(|e| malformed(e.to_string()))?;
        if r.instance.get("env").and_then(Value::as_str) != Some(r.env.as_str()) {
            return Err(malformed(format!("`env` is {:?} but the instance's is {:?}", r.env, r.instance.get("env"))));
        }
        if r.zeta.iter().chain(&r.zeta0).any(|z| !z.is_finite()) {
            return Err(malformed("zeta and zeta0 must be finite".into()));
        }
        Ok(r)
    }

    /// Rebuilds the result's environment from its own instance and checks that ζ, ζ₀ and the
    /// policies fit it.
    pub fn load_env(&self, registry: &Registry, path: impl AsRef<Path>) -> Result<LoadedEnv, ResultError> {
        let path = path.as_ref();
        let malformed = |reason: String| ResultError::Malformed { path: path.to_owned(), reason };
        let env = registry.from_value(&self.instance, path).map_err(|e| malformed(e.to_string()))?;
        let d = env.sampler().zeta_dim();
        if self.zeta.len() != d || self.zeta0.len() != d {
            return Err(malformed(format!("zeta/zeta0 must have {d} entries ({} environment)", env.name)));
        }
        for (what, rows) in [("policy", Some(&self.policy)), ("policy_soft", self.policy_soft.as_ref())] {
            if let Some(rows) = rows {
                crate::policy::pairs_from_rows(env.sampler(), rows).map_err(|e| malformed(format!("{what}: {e}")))?;
            }
        }
        Ok(env)
    }

    /// A parameter of the instance.
    pub fn param(&self, key: &str) -> Option<f64> {
        self.instance.get("params").and_then(|p| p.get(key)).and_then(Value::as_f64)
    }

    /// The instance's name.
    pub fn instance_name(&self) -> &str {
        self.instance.get("name").and_then(Value::as_str).unwrap_or("?")
    }

    /// Writes the file atomically as pretty JSON.
    pub fn save(&self, path: impl AsRef<Path>) -> std::io::Result<()> {
        let text = serde_json::to_string_pretty(self).map_err(std::io::Error::other)?;
        crate::io::write_atomic(path, text.as_bytes())
    }
}

/// Rewrites a v1 file (UAV instance, `kappa` and `eta` beside it) as the v2 file it describes.
fn upgrade_v1(v: &mut Value) -> Result<(), String> {
    let obj = v.as_object_mut().ok_or("expected a JSON object")?;
    let kappa = obj.remove("kappa").and_then(|x| x.as_f64()).ok_or("v1 file without a numeric `kappa`")?;
    let eta = obj.remove("eta").and_then(|x| x.as_f64()).ok_or("v1 file without a numeric `eta`")?;
    let inst = obj.get_mut("instance").and_then(Value::as_object_mut).ok_or("v1 file without an `instance` object")?;
    inst.insert("env".into(), "uav".into());
    inst.insert("params".into(), serde_json::json!({ "kappa": kappa, "eta": eta }));
    obj.insert("env".into(), "uav".into());
    obj.insert("schema".into(), SCHEMA.into());
    Ok(())
}
