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
}

impl<M: ?Sized> std::fmt::Debug for Objective<'_, M> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Objective")
            .field("alpha", &self.alpha)
            .field("form", &self.form)
            .field("gradient", &self.gradient)
            .finish()
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
        Self { mdp, alpha, form, gradient: GradientKind::Exact, fd_step: 1e-6, last: Default::default() }
    }

    /// `J_H(ζ)` and the warm-start policy.
    pub fn value(&self, zeta: &[f64], warm: Option<&[f64]>) -> Result<(f64, Vec<f64>), ModelError> {
        let snap = self.snapshot(zeta);
        let out = self.value_at(&snap, warm);
        self.last.replace(Some(snap));
        out
    }

    fn snapshot(&self, zeta: &[f64]) -> Snapshot {
        Snapshot::build_like(self.mdp, zeta, self.last.borrow().as_ref())
    }

    fn value_at(&self, snap: &Snapshot, warm: Option<&[f64]>) -> Result<(f64, Vec<f64>), ModelError> {
        match self.form {
            Form::Ssp => {
                let sol = solve_soft_retry(snap, self.alpha, warm)?;
                Ok((sol.j, sol.pi))
            }
            Form::Horizon(h) => {
                let sol = solve_horizon_retry(snap, self.alpha, h, warm)?;
                Ok((sol.j, sol.tail.pi))
            }
        }
    }

    /// `J_H(ζ)`, its gradient and the warm-start policy.
    pub fn value_grad(&self, zeta: &[f64], warm: Option<&[f64]>) -> Result<Evaluated, ModelError> {
        let snap = self.snapshot(zeta);
        let out = self.value_grad_at(zeta, &snap, warm);
        self.last.replace(Some(snap));
        out
    }

    fn value_grad_at(&self, zeta: &[f64], snap: &Snapshot, warm: Option<&[f64]>) -> Result<Evaluated, ModelError> {
        let (value, warm_out, exact) = match self.form {
            Form::Ssp => {
                let sol = solve_soft_retry(snap, self.alpha, warm)?;
                let g = match self.gradient {
                    GradientKind::Exact => Some(corollary_gradient(self.mdp, zeta, snap, &sol)?),
                    GradientKind::Fd => None,
                };
                (sol.j, sol.pi, g)
            }
            Form::Horizon(h) => {
                let sol = solve_horizon_retry(snap, self.alpha, h, warm)?;
                let g = match self.gradient {
                    GradientKind::Exact => Some(horizon_gradient(self.mdp, zeta, snap, &sol)?),
                    GradientKind::Fd => None,
                };
                (sol.j, sol.tail.pi, g)
            }
        };
        let grad = match exact {
            Some(g) => g,
            None => fd_gradient(zeta, self.fd_step, |z| self.value(z, Some(&warm_out)).map(|r| r.0))?,
        };
        Ok(Evaluated { value, grad, warm: warm_out })
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
}
