//! What an oracle run returns: each restart's result and per-level trace, and the run's
//! `envpg.result.v2` file.

use envpg_core::policy::policy_rows;
use envpg_core::{LoadedEnv, ResultFile};
use serde::Serialize;

use super::{OracleConfig, RestartKind};
use crate::error::ModelError;
use crate::snapshot::Snapshot;

/// One annealing level of one restart.
#[derive(Debug, Clone, Serialize)]
pub struct Level {
    /// Temperature (0 for the polish level).
    pub alpha: f64,
    /// `"horizon"` or `"ssp"`.
    pub form: &'static str,
    /// J_H at the end of the level.
    pub j_h: f64,
    /// ‖∇ζ J_H‖ at the end of the level.
    pub grad_norm: f64,
    /// L-BFGS iterations.
    pub iterations: usize,
    /// Objective evaluations.
    pub evaluations: usize,
    /// ζ at the end of the level.
    pub zeta: Vec<f64>,
}

/// The result of one restart.
#[derive(Debug, Clone, Serialize)]
pub struct Restart {
    /// Restart index.
    pub index: usize,
    /// Anneal, warm or kick.
    pub kind: RestartKind,
    /// For a kick: the restart whose design it moved.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub from: Option<usize>,
    /// Temperature factor per level.
    pub cooling: f64,
    /// Initial design.
    pub zeta0: Vec<f64>,
    /// Final design.
    pub zeta: Vec<f64>,
    /// Exact J of the final design with its hard-optimal policy.
    #[serde(rename = "J")]
    pub j: f64,
    /// J_H at the last positive temperature.
    #[serde(rename = "J_H")]
    pub j_h: f64,
    /// Levels at or below `alpha_switch` where the soft SSP values did not exist (or
    /// disagreed with the horizon form) and the horizon form was used instead.
    pub ssp_fallbacks: usize,
    /// Per-level trace.
    #[serde(skip)]
    pub levels: Vec<Level>,
    /// Seconds.
    pub seconds: f64,
}

/// The result of an oracle run.
#[derive(Debug, Clone, Serialize)]
pub struct OracleOutcome {
    /// All restarts, by index.
    pub restarts: Vec<Restart>,
    /// Index of the best restart (lowest J, then lowest index; a kick only if better by more than
    /// [`KICK_GAIN`](super::KICK_GAIN)).
    pub best: usize,
    /// Fraction of the restarts before the kicks whose J is within `basin_tol` of the best
    /// (kicks start next to a good design, so they are not counted).
    pub fraction_best: f64,
    /// Hard-optimal policy of the best design, per state–action pair.
    #[serde(skip)]
    pub policy: Vec<f64>,
    /// Wall-clock seconds.
    pub seconds: f64,
}

impl OracleOutcome {
    /// The `envpg.result.v2` file of this run on `env`: the best restart's design and policy,
    /// with every restart summarised in `details` and the best restart's levels as history.
    pub fn to_result(&self, env: &LoadedEnv, cfg: &OracleConfig) -> Result<ResultFile, ModelError> {
        let model = env.model().map_err(|e| ModelError::Invalid(e.to_string()))?;
        let best = &self.restarts[self.best];
        let snap = Snapshot::build(model, &best.zeta);
        let policy = policy_rows(model, &self.policy);
        // Final soft policy at the last positive temperature, for reference.
        let soft = crate::solve_soft(&snap, cfg.alpha_min, None).ok();
        let history = best
            .levels
            .iter()
            .enumerate()
            .map(|(k, l)| envpg_core::result::HistoryRow {
                k: k as u64,
                alpha: l.alpha,
                j_h_estimate: None,
                grad_norm: Some(l.grad_norm),
                zeta: l.zeta.clone(),
                j_exact: None,
                stats: Some(serde_json::json!({ "J_H": l.j_h, "form": l.form, "iterations": l.iterations, "evaluations": l.evaluations })),
            })
            .collect();
        Ok(ResultFile {
            schema: envpg_core::result::SCHEMA.into(),
            method: "oracle".into(),
            env: env.name.into(),
            instance: env.instance.clone(),
            seed: cfg.seed,
            zeta: best.zeta.clone(),
            zeta0: best.zeta0.clone(),
            policy,
            j: Some(best.j),
            j_error: None,
            j_h: Some(best.j_h),
            alpha_final: Some(cfg.alpha_min),
            policy_soft: soft.map(|s| policy_rows(model, &s.pi)),
            seconds: Some(self.seconds),
            config: Some(serde_json::to_value(cfg).expect("config serializes")),
            details: Some(serde_json::json!({
                "best_restart": self.best,
                "fraction_best": self.fraction_best,
                "restarts": self.restarts,
            })),
            history: Some(history),
        })
    }
}
