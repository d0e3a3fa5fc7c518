//! Exact policy evaluation (values, J, J_H) and expected visit counts, solved component by
//! component over the transient states.

use nalgebra::{DMatrix, DVector};

use envpg_core::policy::{PolicyError, pairs_from_rows};
use envpg_core::{ModelMdp, ResultFile};

use crate::error::ModelError;
use crate::snapshot::{Scc, Snapshot};

/// Expected steps within one component above which a policy counts as improper: its values
/// would be dominated by rounding.
pub const MAX_STEPS: f64 = 1e9;

/// The value of one policy.
#[derive(Debug, Clone)]
pub struct PolicyValue {
    /// `V(s)` for every state (0 at terminal states).
    pub v: Vec<f64>,
    /// `Σ_s μ(s) V(s)`.
    pub j: f64,
}

/// `-α Σ π ln π`-style term for one probability: `α·p·ln p`, 0 for `p = 0`.
#[inline]
pub(crate) fn ent(alpha: f64, p: f64) -> f64 {
    if alpha == 0.0 || p <= 0.0 { 0.0 } else { alpha * p * p.ln() }
}

/// Scratch for component-local indexing.
pub(crate) struct Local {
    pub idx: Vec<usize>,
}

impl Local {
    pub fn new(n: usize) -> Self {
        Self { idx: vec![usize::MAX; n] }
    }
    pub fn enter(&mut self, c: &Scc) {
        for (i, &s) in c.states.iter().enumerate() {
            self.idx[s] = i;
        }
    }
    pub fn leave(&mut self, c: &Scc) {
        for &s in &c.states {
            self.idx[s] = usize::MAX;
        }
    }
}

/// Checks (γ = 1) that from every state of cyclic component `c` the policy leaves `c` with
/// positive probability; otherwise the component traps the process forever.
fn check_leaves(snap: &Snapshot, c: &Scc, pi: &[f64], local: &Local) -> Result<(), ModelError> {
    if snap.gamma < 1.0 {
        return Ok(());
    }
    let k = c.states.len();
    let mut leaves = vec![false; k];
    // preds[j] = local states with an edge into local state j under π.
    let mut preds: Vec<Vec<usize>> = vec![Vec::new(); k];
    for (i, &s) in c.states.iter().enumerate() {
        for sa in snap.sas(s) {
            if pi[sa] <= 0.0 {
                continue;
            }
            for o in snap.outs(sa) {
                if snap.prob[o] <= 0.0 {
                    continue;
                }
                match local.idx[snap.next[o]] {
                    usize::MAX => leaves[i] = true,
                    j => preds[j].push(i),
                }
            }
        }
    }
    let mut queue: Vec<usize> = (0..k).filter(|&i| leaves[i]).collect();
    while let Some(j) = queue.pop() {
        for &i in &preds[j] {
            if !leaves[i] {
                leaves[i] = true;
                queue.push(i);
            }
        }
    }
    let stuck: Vec<usize> = (0..k).filter(|&i| !leaves[i]).map(|i| c.states[i]).collect();
    if stuck.is_empty() { Ok(()) } else { Err(ModelError::Improper { states: stuck }) }
}

/// Evaluates `pi` (per state–action pair) on cyclic component `c`, writing `v` of its states;
/// values of states outside `c` must already be final.
pub(crate) fn eval_component(
    snap: &Snapshot,
    c: &Scc,
    pi: &[f64],
    alpha: f64,
    v: &mut [f64],
    local: &Local,
) -> Result<(), ModelError> {
    check_leaves(snap, c, pi, local)?;
    let k = c.states.len();
    let mut a = DMatrix::<f64>::identity(k, k);
    let mut b = DVector::<f64>::zeros(k);
    for (i, &s) in c.states.iter().enumerate() {
        for sa in snap.sas(s) {
            let w = pi[sa];
            if w == 0.0 {
                continue;
            }
            b[i] += w * snap.rbar[sa] + ent(alpha, w);
            for o in snap.outs(sa) {
                let t = snap.next[o];
                let p = snap.gamma * w * snap.prob[o];
                match local.idx[t] {
                    usize::MAX => b[i] += p * v[t],
                    j => a[(i, j)] -= p,
                }
            }
        }
    }
    let lu = a.lu();
    let x = lu.solve(&b).ok_or(ModelError::Singular("policy evaluation"))?;
    if x.iter().any(|x| !x.is_finite()) {
        return Err(ModelError::Singular("policy evaluation"));
    }
    if snap.gamma == 1.0 {
        // Exits whose probability underflows towards 0 pass the support check yet leave the
        // system numerically singular. Expected steps in the component (same factorisation)
        // tell: beyond MAX_STEPS the values are meaningless, so treat the policy as improper.
        // Every state takes at least one step, so a computed τ < 1 (even negative) is the
        // rounding garbage of a numerically singular system, not a short stay.
        let tau = lu.solve(&DVector::from_element(k, 1.0)).ok_or(ModelError::Singular("policy evaluation"))?;
        let stuck: Vec<usize> = c
            .states
            .iter()
            .enumerate()
            .filter(|&(i, _)| !(tau[i].is_finite() && (1.0 - 1e-9..MAX_STEPS).contains(&tau[i])))
            .map(|(_, &s)| s)
            .collect();
        if !stuck.is_empty() {
            return Err(ModelError::Improper { states: stuck });
        }
    }
    for (i, &s) in c.states.iter().enumerate() {
        v[s] = x[i];
    }
    Ok(())
}

/// Value of an acyclic state under `pi`, given the values of its successors.
#[inline]
pub(crate) fn eval_state(snap: &Snapshot, s: usize, pi: &[f64], alpha: f64, v: &[f64]) -> f64 {
    snap.sas(s)
        .filter(|&sa| pi[sa] != 0.0)
        .map(|sa| pi[sa] * (snap.rbar[sa] + snap.gamma * snap.expect(sa, v)) + ent(alpha, pi[sa]))
        .sum()
}

/// What a result file's own contents score to, recomputed rather than read.
#[derive(Debug, Clone)]
pub struct Rescored {
    /// Exact J of (ζ, policy); an error when the policy does not terminate from some state.
    pub j: Result<f64, ModelError>,
    /// J_H of the soft policy at the final temperature, when the file has both and it is finite.
    pub j_h: Option<f64>,
}

/// Rescores result file `r` on `model` (the environment of its own instance): J of its ζ and
/// policy, and J_H of its soft policy. Fails only when the policy rows do not fit the model.
pub fn rescore<M: ModelMdp + ?Sized>(model: &M, r: &ResultFile) -> Result<Rescored, PolicyError> {
    let snap = Snapshot::build(model, &r.zeta);
    let pi = pairs_from_rows(model, &r.policy)?;
    let j = evaluate(&snap, &pi, 0.0).map(|v| v.j);
    let j_h = match (&r.policy_soft, r.alpha_final) {
        (Some(soft), Some(alpha)) => evaluate(&snap, &pairs_from_rows(model, soft)?, alpha).ok().map(|v| v.j),
        _ => None,
    };
    Ok(Rescored { j, j_h })
}

/// Exact values of policy `pi` (probabilities per state–action pair of `snap`) with entropy
/// temperature `alpha` (0 for the plain objective J; > 0 for J_H).
pub fn evaluate(snap: &Snapshot, pi: &[f64], alpha: f64) -> Result<PolicyValue, ModelError> {
    if pi.len() != snap.n_pairs() {
        return Err(ModelError::Invalid(format!(
            "policy has {} entries, model has {} pairs",
            pi.len(),
            snap.n_pairs()
        )));
    }
    let mut v = vec![0.0; snap.n_states];
    let mut local = Local::new(snap.n_states);
    for c in snap.sccs.iter() {
        if c.cyclic {
            local.enter(c);
            let r = eval_component(snap, c, pi, alpha, &mut v, &local);
            local.leave(c);
            r?;
        } else {
            let s = c.states[0];
            if !snap.terminal[s] {
                v[s] = eval_state(snap, s, pi, alpha, &v);
            }
        }
    }
    let j = snap.mu.iter().map(|&(s, p)| p * v[s]).sum();
    Ok(PolicyValue { v, j })
}

/// Expected (discounted) visit counts `ρᵀ = initᵀ (I − γ P_π)⁻¹` of every state under `pi`,
/// starting from the dense distribution `init`.
pub fn visits(snap: &Snapshot, pi: &[f64], init: &[f64]) -> Result<Vec<f64>, ModelError> {
    let mut inflow = init.to_vec();
    let mut rho = vec![0.0; snap.n_states];
    let mut local = Local::new(snap.n_states);
    for c in snap.sccs.iter().rev() {
        if c.cyclic {
            local.enter(c);
            let res = (|| {
                check_leaves(snap, c, pi, &local)?;
                let k = c.states.len();
                // Build (I − γ P_CC)ᵀ directly.
                let mut a = DMatrix::<f64>::identity(k, k);
                let b = DVector::from_iterator(k, c.states.iter().map(|&s| inflow[s]));
                for (i, &s) in c.states.iter().enumerate() {
                    for sa in snap.sas(s) {
                        let w = pi[sa];
                        if w == 0.0 {
                            continue;
                        }
                        for o in snap.outs(sa) {
                            let j = local.idx[snap.next[o]];
                            if j != usize::MAX {
                                a[(j, i)] -= snap.gamma * w * snap.prob[o];
                            }
                        }
                    }
                }
                let x = a.lu().solve(&b).ok_or(ModelError::Singular("visit counts"))?;
                if x.iter().any(|x| !x.is_finite()) {
                    return Err(ModelError::Singular("visit counts"));
                }
                for (i, &s) in c.states.iter().enumerate() {
                    rho[s] = x[i];
                }
                Ok(())
            })();
            if let Err(e) = res {
                local.leave(c);
                return Err(e);
            }
            for &s in &c.states {
                push_out(snap, s, pi, rho[s], &local, &mut inflow);
            }
            local.leave(c);
        } else {
            let s = c.states[0];
            rho[s] = inflow[s];
            push_out(snap, s, pi, rho[s], &local, &mut inflow);
        }
    }
    Ok(rho)
}

/// Sends the flow `mass` of state `s` under `pi` to successors outside the current component.
#[inline]
fn push_out(snap: &Snapshot, s: usize, pi: &[f64], mass: f64, local: &Local, inflow: &mut [f64]) {
    if mass == 0.0 {
        return;
    }
    for sa in snap.sas(s) {
        let w = pi[sa] * mass * snap.gamma;
        if w == 0.0 {
            continue;
        }
        for o in snap.outs(sa) {
            let t = snap.next[o];
            if local.idx[t] == usize::MAX {
                inflow[t] += w * snap.prob[o];
            }
        }
    }
}

/// The dense initial distribution μ of `snap`.
pub fn mu_dense(snap: &Snapshot) -> Vec<f64> {
    let mut mu = vec![0.0; snap.n_states];
    for &(s, p) in snap.mu.iter() {
        mu[s] += p;
    }
    mu
}

/// The hard-optimal policy of `model` at `zeta` and its exact J.
pub fn optimal_greedy<M: envpg_core::ModelMdp + ?Sized>(
    model: &M,
    zeta: &[f64],
) -> Result<(Snapshot, Vec<f64>, f64), ModelError> {
    let snap = Snapshot::build(model, zeta);
    let sol = crate::soft::solve_soft(&snap, 0.0, None)?;
    let j = evaluate(&snap, &sol.pi, 0.0)?.j;
    Ok((snap, sol.pi, j))
}

/// Exact J of the greedy (most probable action) version of `pi` at `snap`.
pub fn greedy_j(snap: &Snapshot, pi: &[f64]) -> Result<(Vec<f64>, f64), ModelError> {
    let g = crate::soft::greedy(snap, pi);
    let j = evaluate(snap, &g, 0.0)?.j;
    Ok((g, j))
}
