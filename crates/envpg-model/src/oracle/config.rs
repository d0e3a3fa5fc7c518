//! [`OracleConfig`]: the oracle's settings, their defaults from the environment's hints, and
//! what they make of each restart (its kind, cooling and temperatures).

use envpg_core::ModelMdp;
use serde::Serialize;

use crate::error::ModelError;
use crate::objective::GradientKind;

/// Which kinds of restart an oracle run uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Strategy {
    /// A portfolio when the model is deterministic (at the first ζ₀), mixed otherwise.
    Auto,
    /// Every restart anneals from hot.
    Anneal,
    /// Every restart starts warm from its ζ₀.
    Warm,
    /// One anneal restart, the others warm.
    Mixed,
    /// The first restart anneals at `cooling`; then warm and faster anneal restarts alternate,
    /// the faster ones cooling by `cooling²`, `cooling³`, `cooling⁴` per level in turn. Warm
    /// restarts start from the environment's clustered design, if it has one (else random).
    Portfolio,
}

/// The kind of one restart.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum RestartKind {
    /// Deterministic annealing from hot.
    Anneal,
    /// Warm start from ζ₀.
    Warm,
    /// Warm start from the best design of the restarts so far, moved by Gaussian noise
    /// ([`OracleConfig::kicks`]).
    Kick,
    /// Colder warm start from the best design so far with one design element moved
    /// ([`OracleConfig::relocations`]).
    Relocation,
}

/// Oracle settings. [`OracleConfig::for_env`] gives the defaults.
#[derive(Debug, Clone, Serialize)]
pub struct OracleConfig {
    /// Number of restarts (the best is kept).
    pub restarts: usize,
    /// Seed of ζ₀ draws and annealing noise.
    pub seed: u64,
    /// Kinds of restart.
    pub strategy: Strategy,
    /// Starting temperature of anneal restarts.
    pub alpha0: f64,
    /// Starting temperature of warm restarts.
    pub warm_alpha0: f64,
    /// Last positive temperature.
    pub alpha_min: f64,
    /// Factor per level (0 < cooling < 1).
    pub cooling: f64,
    /// Levels hotter than this use the finite-horizon form.
    pub alpha_switch: f64,
    /// Horizon H of the finite-horizon form.
    pub horizon: usize,
    /// Exact or finite-difference gradients.
    pub gradient: GradientKind,
    /// L-BFGS iterations per level.
    pub iters_per_level: usize,
    /// Levels hotter than `alpha_min` stop once an L-BFGS step is shorter than this, in units
    /// of the instance's length scale: they only track the minimiser the next, colder level
    /// starts from (and an anneal's hot levels move ζ by `perturb` anyway). The last positive
    /// level and the polish converge fully. 0: every level converges fully.
    pub tracking_tol: f64,
    /// ζ₀ of the first restart (others are random).
    pub init: Option<Vec<f64>>,
    /// Symmetry-breaking noise added at each horizon-form level (std, in units of the
    /// instance's length scale).
    pub perturb: f64,
    /// Relative tolerance on J for "reached the best design".
    pub basin_tol: f64,
    /// Worker threads for restarts.
    pub threads: usize,
    /// Polish at α = 0 after the last level.
    pub polish: bool,
    /// Kicks after the restarts (basin hopping): warm restarts from the best design found so
    /// far, moved by Gaussian noise first, [`KICKS_PER_ROUND`] at a time, each round from the
    /// best design after the one before. `None`: [`DEFAULT_KICKS`] with a portfolio, none
    /// otherwise.
    pub kicks: Option<usize>,
    /// Standard deviation of kick `k`'s noise: `kick_scale · 2^(k mod 3)` in units of the
    /// instance's length scale.
    pub kick_scale: f64,
    /// Relocation kicks after the Gaussian ones: warm restarts from the best design so far
    /// with one design element (a relay, a facility) moved to serve a costly hop, two per round
    /// like the kicks (see the `relocate` module). `None`: [`DEFAULT_RELOCATIONS`] with a
    /// portfolio on an environment with at least two design elements, none otherwise.
    pub relocations: Option<usize>,
    /// Starting temperature of relocation kicks; `None`: a tenth of `warm_alpha0`. Colder
    /// than the warm restarts: from `warm_alpha0` a moved UAV's users are shared out again and
    /// the restart drifts back into the basin it was moved out of.
    pub relocation_alpha0: Option<f64>,
}

/// Kicks of a portfolio run unless [`OracleConfig::kicks`] says otherwise.
pub const DEFAULT_KICKS: usize = 6;

/// Relocation kicks of a portfolio run unless [`OracleConfig::relocations`] says otherwise.
pub const DEFAULT_RELOCATIONS: usize = 4;

/// Kicks started from the same best design: a round is a fixed number, so that the designs (and
/// the result) do not depend on the thread count; two keep two threads busy.
pub const KICKS_PER_ROUND: usize = 2;

impl OracleConfig {
    /// Defaults scaled to the environment ([`ModelMdp::oracle_hints`]): a hot start at 10× its
    /// cost scale (for the UAV network, the squared extent of the instance), warm starts and
    /// the last temperature as hinted, cooling ×0.8 per level, SSP below 1% of the cost scale.
    pub fn for_env<M: ModelMdp + ?Sized>(model: &M) -> Self {
        let hints = model.oracle_hints();
        let scale = hints.cost_scale;
        Self {
            restarts: 16,
            seed: 1,
            strategy: Strategy::Auto,
            alpha0: 10.0 * scale,
            warm_alpha0: hints.warm_alpha0,
            alpha_min: hints.alpha_min,
            cooling: 0.8,
            alpha_switch: 0.01 * scale,
            horizon: hints.horizon,
            gradient: GradientKind::Exact,
            iters_per_level: 30,
            tracking_tol: 1e-4,
            init: None,
            perturb: 1e-3,
            basin_tol: 1e-4,
            threads: std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1),
            polish: true,
            kicks: None,
            kick_scale: 0.01,
            relocations: None,
            relocation_alpha0: None,
        }
    }

    /// Checks ranges (and `init` against the environment's design space).
    pub fn validate<M: ModelMdp + ?Sized>(&self, model: &M) -> Result<(), ModelError> {
        let bad = |m: String| Err(ModelError::Invalid(m));
        if self.restarts == 0 {
            return bad("restarts must be at least 1".into());
        }
        if !(self.alpha0.is_finite() && self.alpha0 > 0.0) {
            return bad(format!("alpha0 must be finite and > 0, got {}", self.alpha0));
        }
        if !(self.warm_alpha0.is_finite() && self.warm_alpha0 > 0.0) {
            return bad(format!("warm_alpha0 must be finite and > 0, got {}", self.warm_alpha0));
        }
        if let Some(a) = self.relocation_alpha0
            && !(a.is_finite() && a > 0.0)
        {
            return bad(format!("relocation_alpha0 must be finite and > 0, got {a}"));
        }
        if !(self.alpha_min.is_finite() && self.alpha_min > 0.0 && self.alpha_min <= self.alpha0.min(self.warm_alpha0))
        {
            return bad(format!("alpha_min must be in (0, min(alpha0, warm_alpha0)], got {}", self.alpha_min));
        }
        if !(self.cooling > 0.0 && self.cooling < 1.0) {
            return bad(format!("cooling must be in (0, 1), got {}", self.cooling));
        }
        if !(self.alpha_switch.is_finite() && self.alpha_switch >= 0.0) {
            return bad(format!("alpha_switch must be finite and >= 0, got {}", self.alpha_switch));
        }
        if self.horizon == 0 {
            return bad("horizon must be at least 1".into());
        }
        if !(self.perturb.is_finite() && self.perturb >= 0.0) {
            return bad(format!("perturb must be finite and >= 0, got {}", self.perturb));
        }
        if !(self.tracking_tol.is_finite() && self.tracking_tol >= 0.0) {
            return bad(format!("tracking_tol must be finite and >= 0, got {}", self.tracking_tol));
        }
        if self.threads == 0 {
            return bad("threads must be at least 1".into());
        }
        if !(self.kick_scale.is_finite() && self.kick_scale > 0.0) {
            return bad(format!("kick_scale must be finite and > 0, got {}", self.kick_scale));
        }
        if let Some(z) = &self.init {
            model.zeta_space().check(z).map_err(|e| ModelError::Invalid(format!("init: {e}")))?;
        }
        Ok(())
    }

    /// The kind of restart `r`: `init` (if any) is restart 0 and starts warm; with a mixed
    /// strategy the first other restart anneals; `Auto` is a portfolio for a `deterministic`
    /// model and mixed otherwise; restarts from `restarts` on are kicks, and after the kicks
    /// relocations.
    pub fn restart_kind(&self, r: usize, deterministic: bool) -> RestartKind {
        let first_free = usize::from(self.init.is_some());
        match (self.strategy, r) {
            (_, r) if r >= self.restarts + self.kick_count(deterministic) => RestartKind::Relocation,
            (_, r) if r >= self.restarts => RestartKind::Kick,
            (_, 0) if self.init.is_some() => RestartKind::Warm,
            (Strategy::Anneal, _) => RestartKind::Anneal,
            (Strategy::Warm, _) => RestartKind::Warm,
            (Strategy::Portfolio, r) | (Strategy::Auto, r) if self.portfolio(deterministic) => {
                if (r - first_free) % 2 == 0 { RestartKind::Anneal } else { RestartKind::Warm }
            }
            (Strategy::Auto | Strategy::Mixed, r) if r == first_free => RestartKind::Anneal,
            (Strategy::Auto | Strategy::Mixed | Strategy::Portfolio, _) => RestartKind::Warm,
        }
    }

    /// Whether restarts form a portfolio (see [`Strategy::Portfolio`]).
    pub(super) fn portfolio(&self, deterministic: bool) -> bool {
        self.strategy == Strategy::Portfolio || (self.strategy == Strategy::Auto && deterministic)
    }

    /// The number of kicks after the restarts ([`OracleConfig::kicks`]).
    pub fn kick_count(&self, deterministic: bool) -> usize {
        self.kicks.unwrap_or(if self.portfolio(deterministic) { DEFAULT_KICKS } else { 0 })
    }

    /// The number of relocation kicks after the kicks ([`OracleConfig::relocations`]) on
    /// `model`: none where it has fewer than two design elements.
    pub fn relocation_count<M: ModelMdp + ?Sized>(&self, model: &M, deterministic: bool) -> usize {
        if model.design_elements().len() < 2 {
            return 0;
        }
        self.relocations.unwrap_or(if self.portfolio(deterministic) { DEFAULT_RELOCATIONS } else { 0 })
    }

    /// The cooling factor of restart `r`: `cooling`, except for the faster anneal restarts of a
    /// portfolio. At slow cooling the annealing path follows one branch of its bifurcations
    /// whatever the noise, and on large UAV instances that branch is often a poor basin; faster
    /// schedules are cheaper and, with the symmetry-breaking noise, take different branches.
    pub fn restart_cooling(&self, r: usize, deterministic: bool) -> f64 {
        let first_free = usize::from(self.init.is_some());
        if !self.portfolio(deterministic)
            || r <= first_free
            || self.restart_kind(r, deterministic) != RestartKind::Anneal
        {
            return self.cooling;
        }
        let m = (r - first_free) / 2; // 1, 2, 3, … for the 2nd, 3rd, 4th… anneal restart
        self.cooling.powi(2 + ((m - 1) % 3) as i32)
    }

    /// The positive temperatures of a restart of kind `kind` cooling by `cooling` per level.
    pub fn schedule(&self, kind: RestartKind, cooling: f64) -> Vec<f64> {
        let mut out = Vec::new();
        let mut a = match kind {
            RestartKind::Anneal => self.alpha0,
            RestartKind::Warm | RestartKind::Kick => self.warm_alpha0,
            // Never below `alpha_min`: the schedule then holds `alpha_min` alone.
            RestartKind::Relocation => self.relocation_alpha0.unwrap_or(0.1 * self.warm_alpha0),
        };
        while a > self.alpha_min * (1.0 + 1e-12) {
            out.push(a);
            a *= cooling;
        }
        out.push(self.alpha_min);
        out
    }
}
