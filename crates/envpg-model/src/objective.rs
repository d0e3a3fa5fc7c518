//! [`Objective`]: the entropy-regularised objective `J_H(ζ)` of the soft-optimal policy at one
//! temperature, in SSP or finite-horizon form, with its gradient (exact or central differences).

use envpg_core::ModelMdp;

use crate::error::ModelError;
use crate::grad::{corollary_gradient, fd_gradient, horizon_gradient};
use crate::horizon::solve_horizon;
use crate::snapshot::Snapshot;
use crate::soft::solve_soft;

/// How the soft problem is posed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Form {
    /// The stochastic shortest path (or discounted) problem itself.
    Ssp,
    /// `H` soft stages, then the hard-optimal SSP policy.
    Horizon(usize),
}

/// How the ζ-gradient is computed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum GradientKind {
    /// Exactly from the model (visits × local derivative).
    Exact,
    /// Central differences of J_H over every coordinate, as the paper's oracle.
    Fd,
}

/// `J_H` at temperature `alpha` in form `form`.
pub struct Objective<'a, M: ?Sized> {
    /// The model.
    pub mdp: &'a M,
    /// Temperature (0: the hard objective J of the optimal policy).
    pub alpha: f64,
    /// SSP or finite horizon.
    pub form: Form,
    /// Gradient method.
    pub gradient: GradientKind,
    /// Step of central differences.
    pub fd_step: f64,
    /// The last snapshot, whose component decomposition the next one reuses.
    last: std::cell::RefCell<Option<Snapshot>>,
    /// This objective among all (see `generation`).
    id: u64,
    /// How many snapshots have been stored in `last`: with `id`, tells [`Objective::gradient`]
    /// whether `last` is still its point's.
    generation: std::cell::Cell<u64>,
}

/// Source of [`Objective`] ids.
static OBJECTIVES: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

impl<M: ?Sized> std::fmt::Debug for Objective<'_, M> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Objective")
            .field("alpha", &self.alpha)
            .field("form", &self.form)
            .field("gradient", &self.gradient)
            .finish()
    }
}

/// The soft problem solved at one ζ, its gradient not yet computed: what
/// [`Objective::solve`] returns and [`Objective::gradient`] finishes.
#[derive(Debug, Clone)]
pub struct Solved {
    /// `J_H(ζ)`.
    pub value: f64,
    zeta: Vec<f64>,
    solution: Solution,
    /// The objective and its snapshot generation this solution was computed on.
    on: (u64, u64),
}

#[derive(Debug, Clone)]
enum Solution {
    Ssp(crate::SoftSolution),
    Horizon(crate::HorizonSolution),
}

impl Solution {
    fn j(&self) -> f64 {
        match self {
            Solution::Ssp(sol) => sol.j,
            Solution::Horizon(sol) => sol.j,
        }
    }

    fn warm(&self) -> &[f64] {
        match self {
            Solution::Ssp(sol) => &sol.pi,
            Solution::Horizon(sol) => &sol.tail.pi,
        }
    }
}

impl Solved {
    /// The SSP policy (or the horizon's hard tail) per state–action pair: the warm start of
    /// the next solve.
    pub fn warm(&self) -> &[f64] {
        self.solution.warm()
    }

    /// The warm start, by value.
    pub fn into_warm(self) -> Vec<f64> {
        match self.solution {
            Solution::Ssp(sol) => sol.pi,
            Solution::Horizon(sol) => sol.tail.pi,
        }
    }
}

/// Value and gradient at one ζ, with the policy to warm-start the next solve from.
#[derive(Debug, Clone)]
pub struct Evaluated {
    /// `J_H(ζ)`.
    pub value: f64,
    /// `∇ζ J_H(ζ)`.
    pub grad: Vec<f64>,
    /// The SSP policy (or the horizon's hard tail) per state–action pair.
    pub warm: Vec<f64>,
}

impl<'a, M: ModelMdp + ?Sized> Objective<'a, M> {
    /// The objective at `alpha` in `form`, exact gradient.
    pub fn new(mdp: &'a M, alpha: f64, form: Form) -> Self {
        Self {
            mdp,
            alpha,
            form,
            gradient: GradientKind::Exact,
            fd_step: 1e-6,
            last: Default::default(),
            id: OBJECTIVES.fetch_add(1, std::sync::atomic::Ordering::Relaxed),
            generation: Default::default(),
        }
    }

    /// `J_H(ζ)` and the warm-start policy.
    pub fn value(&self, zeta: &[f64], warm: Option<&[f64]>) -> Result<(f64, Vec<f64>), ModelError> {
        self.solve(zeta, warm).map(|s| (s.value, s.into_warm()))
    }

    fn keep(&self, snap: Snapshot) {
        self.last.replace(Some(snap));
        self.generation.set(self.generation.get() + 1);
    }

    fn snapshot(&self, zeta: &[f64]) -> Snapshot {
        Snapshot::build_like(self.mdp, zeta, self.last.borrow().as_ref())
    }

    /// `J_H(ζ)`, its gradient and the warm-start policy.
    pub fn value_grad(&self, zeta: &[f64], warm: Option<&[f64]>) -> Result<Evaluated, ModelError> {
        let solved = self.solve(zeta, warm)?;
        let grad = self.gradient(&solved)?;
        Ok(Evaluated { value: solved.value, grad, warm: solved.into_warm() })
    }

    /// Solves the soft problem at `zeta` (warm-started from `warm`), leaving the gradient to
    /// [`Objective::gradient`] — a line search needs it only at the step it accepts.
    pub fn solve(&self, zeta: &[f64], warm: Option<&[f64]>) -> Result<Solved, ModelError> {
        let snap = self.snapshot(zeta);
        let solution = match self.form {
            Form::Ssp => solve_soft_retry(&snap, self.alpha, warm).map(Solution::Ssp),
            Form::Horizon(h) => solve_horizon_retry(&snap, self.alpha, h, warm).map(Solution::Horizon),
        };
        self.keep(snap);
        let solution = solution?;
        Ok(Solved { value: solution.j(), zeta: zeta.to_vec(), solution, on: (self.id, self.generation.get()) })
    }

    /// `∇ζ J_H` at a point [`Objective::solve`]d by this objective (or another of the same
    /// model). The exact gradient reads the snapshot the solve kept, rebuilt if this objective
    /// has built another since.
    pub fn gradient(&self, solved: &Solved) -> Result<Vec<f64>, ModelError> {
        let Solved { zeta, solution, on, .. } = solved;
        let exact = |snap: &Snapshot| match solution {
            Solution::Ssp(sol) => corollary_gradient(self.mdp, zeta, snap, sol),
            Solution::Horizon(sol) => horizon_gradient(self.mdp, zeta, snap, sol),
        };
        match self.gradient {
            GradientKind::Exact if *on == (self.id, self.generation.get()) => {
                exact(self.last.borrow().as_ref().expect("solve keeps its snapshot"))
            }
            GradientKind::Exact => exact(&Snapshot::build_like(self.mdp, zeta, self.last.borrow().as_ref())),
            GradientKind::Fd => fd_gradient(zeta, self.fd_step, |z| self.value(z, Some(solution.warm())).map(|r| r.0)),
        }
    }
}

/// Solves from the warm start, falling back to a cold start if the warm policy is unusable
/// (e.g. an improper hard policy).
fn solve_soft_retry(snap: &Snapshot, alpha: f64, warm: Option<&[f64]>) -> Result<crate::SoftSolution, ModelError> {
    match solve_soft(snap, alpha, warm) {
        Err(ModelError::Improper { .. } | ModelError::Singular(_) | ModelError::NotConverged { .. })
            if warm.is_some() =>
        {
            solve_soft(snap, alpha, None)
        }
        r => r,
    }
}

fn solve_horizon_retry(
    snap: &Snapshot,
    alpha: f64,
    h: usize,
    warm: Option<&[f64]>,
) -> Result<crate::HorizonSolution, ModelError> {
    match solve_horizon(snap, alpha, h, warm) {
        Err(ModelError::Improper { .. } | ModelError::Singular(_) | ModelError::NotConverged { .. })
            if warm.is_some() =>
        {
            solve_horizon(snap, alpha, h, None)
        }
        r => r,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The oracle keeps one objective per form across a restart's levels: one that evaluated
    /// another design at another temperature first (and reuses that snapshot's components and
    /// stages) gives the bits of a fresh one.
    #[test]
    fn an_objective_reused_across_designs_and_temperatures_gives_a_fresh_ones_bits() {
        for kappa in [1.0, 0.85] {
            let env = envpg_envs::registry().load("uav271", &[("kappa".into(), kappa)]).unwrap();
            let model = env.model().unwrap();
            let zeta = model.heuristic_design().unwrap();
            let other: Vec<f64> = zeta.iter().map(|z| z + 0.3).collect();
            for form in [Form::Ssp, Form::Horizon(model.oracle_hints().horizon)] {
                let mut reused = Objective::new(model, 0.5, form);
                reused.value_grad(&other, None).unwrap();
                reused.alpha = 0.3;
                let a = reused.value_grad(&zeta, None).unwrap();
                let b = Objective::new(model, 0.3, form).value_grad(&zeta, None).unwrap();
                let bits = |e: &Evaluated| {
                    let mut v = vec![e.value.to_bits()];
                    v.extend(e.grad.iter().chain(&e.warm).map(|x| x.to_bits()));
                    v
                };
                assert_eq!(bits(&a), bits(&b), "kappa {kappa}, {form:?}");
            }
        }
    }

    /// Solving first and finishing the gradient later gives `value_grad`'s bits, also when the
    /// objective has solved at another point in between or another objective finishes it (the
    /// snapshot is then rebuilt), with either kind of gradient.
    #[test]
    fn a_gradient_finished_after_the_solve_gives_value_grads_bits() {
        let env = envpg_envs::registry().load("uav271", &[("kappa".into(), 0.9)]).unwrap();
        let model = env.model().unwrap();
        let zeta = model.heuristic_design().unwrap();
        let other: Vec<f64> = zeta.iter().map(|z| z + 0.2).collect();
        let bits = |e: &Evaluated| {
            let mut v = vec![e.value.to_bits()];
            v.extend(e.grad.iter().chain(&e.warm).map(|x| x.to_bits()));
            v
        };
        for form in [Form::Ssp, Form::Horizon(model.oracle_hints().horizon)] {
            for kind in [GradientKind::Exact, GradientKind::Fd] {
                let mut obj = Objective::new(model, 0.4, form);
                obj.gradient = kind;
                let eager = obj.value_grad(&zeta, None).unwrap();
                let solved = obj.solve(&zeta, None).unwrap();
                assert_eq!(solved.value.to_bits(), eager.value.to_bits());
                assert_eq!(solved.warm(), &eager.warm[..]);
                let at_once = obj.gradient(&solved).unwrap();
                let solved_again = obj.solve(&zeta, None).unwrap();
                obj.solve(&other, None).unwrap();
                let later = obj.gradient(&solved_again).unwrap();
                let mut another = Objective::new(model, 0.4, form);
                another.gradient = kind;
                let elsewhere = another.gradient(&solved_again).unwrap();
                let finished = |grad| Evaluated { value: solved.value, grad, warm: solved.warm().to_vec() };
                assert_eq!(bits(&finished(at_once)), bits(&eager), "{form:?} {kind:?}");
                assert_eq!(bits(&finished(later)), bits(&eager), "{form:?} {kind:?}, after another solve");
                assert_eq!(bits(&finished(elsewhere)), bits(&eager), "{form:?} {kind:?}, by another objective");
            }
        }
    }
}
