//! Soft (entropy-regularised) value iteration for the SSP / discounted MDP, and its α = 0 limit.
//!
//! Solved component by component: acyclic states take one soft-min backup; each cyclic
//! component runs soft policy iteration (exact evaluation of the Gibbs policy, then improvement)
//! until the soft Bellman residual vanishes. For α = 0 this is ordinary policy iteration.
//!
//! With γ = 1 and α large compared with the costs of cycles, no fixed point exists: looping
//! earns `−α ln π` per step faster than it costs, and the soft values run to −∞. Soft policy
//! iteration decreases the values monotonically, so divergence shows as values falling below
//! any bound a proper solution can have; it is reported as [`ModelError::Diverged`].

use crate::error::ModelError;
use crate::evaluate::{Local, eval_component};
use crate::snapshot::Snapshot;

/// Maximum policy-iteration sweeps per component.
const MAX_SWEEPS: usize = 500;
/// A fixed point has `V ≥ −α·ln|A|·E[steps]`; below this many expected steps we call it diverged.
const MAX_EXPECTED_STEPS: f64 = 1e7;

/// The soft-optimal solution at one temperature.
#[derive(Debug, Clone)]
pub struct SoftSolution {
    /// Temperature α (0: hard optimum).
    pub alpha: f64,
    /// Soft values `V^H(s)` (0 at terminal states).
    pub v: Vec<f64>,
    /// Gibbs policy per state–action pair (one-hot for α = 0).
    pub pi: Vec<f64>,
    /// `Σ μ V`.
    pub j: f64,
}

/// Soft-min backup of state `s` from successor values `v`: returns `V(s)` and writes the Gibbs
/// policy of `s` into `pi_s` (one entry per pair of `s`). For α = 0 picks an argmin, preferring
/// the action `pi_s` already holds.
#[inline]
pub(crate) fn backup(snap: &Snapshot, s: usize, alpha: f64, v: &[f64], pi_s: &mut [f64], qbuf: &mut Vec<f64>) -> f64 {
    let r = snap.sas(s);
    debug_assert_eq!(pi_s.len(), r.len());
    qbuf.clear();
    qbuf.extend(r.map(|sa| snap.rbar[sa] + snap.gamma * snap.expect(sa, v)));
    let qmin = qbuf.iter().copied().fold(f64::INFINITY, f64::min);
    if alpha == 0.0 {
        let current = pi_s.iter().position(|&p| p == 1.0);
        let tol = 1e-12 * (1.0 + qmin.abs());
        let pick = match current {
            Some(i) if qbuf[i] <= qmin + tol => i,
            _ => qbuf.iter().position(|&q| q == qmin).expect("non-empty"),
        };
        for (i, p) in pi_s.iter_mut().enumerate() {
            *p = if i == pick { 1.0 } else { 0.0 };
        }
        return qmin;
    }
    let mut z = 0.0;
    for (p, &q) in pi_s.iter_mut().zip(qbuf.iter()) {
        let x = -(q - qmin) / alpha;
        // exp underflows to exactly 0 below −745.2: skip the call (most actions of most states
        // at low α), same bits.
        // The best action's exp(−0) is exactly 1: skip that call too.
        let e = if x < -746.0 {
            0.0
        } else if x == 0.0 {
            1.0
        } else {
            x.exp()
        };
        *p = e;
        z += e;
    }
    for p in pi_s.iter_mut() {
        *p /= z;
    }
    qmin - alpha * z.ln()
}

/// Solves the soft-optimal problem at temperature `alpha` (≥ 0).
///
/// `warm` is an optional policy (per pair) to start policy iteration from — typically the
/// solution at a nearby ζ or α; it must be proper for α = 0.
pub fn solve_soft(snap: &Snapshot, alpha: f64, warm: Option<&[f64]>) -> Result<SoftSolution, ModelError> {
    solve_soft_within(snap, alpha, warm, None)
}

/// [`solve_soft`] on the states flagged in `within` only (every state if `None`); `within`
/// must be closed under successors. Elsewhere `v` is 0, `pi` the warm start (or uniform) and
/// `j` NaN.
pub(crate) fn solve_soft_within(
    snap: &Snapshot,
    alpha: f64,
    warm: Option<&[f64]>,
    within: Option<&[bool]>,
) -> Result<SoftSolution, ModelError> {
    if !(alpha.is_finite() && alpha >= 0.0) {
        return Err(ModelError::Invalid(format!("alpha must be finite and >= 0, got {alpha}")));
    }
    let n = snap.n_states;
    let mut v = vec![0.0; n];
    let mut pi: Vec<f64> = match warm {
        Some(w) if w.len() == snap.n_pairs() => w.to_vec(),
        _ => uniform(snap),
    };
    let mut local = Local::new(n);
    let mut qbuf = Vec::new();
    let max_actions = (0..n).map(|s| snap.sas(s).len()).max().unwrap_or(1).max(2) as f64;
    for c in snap.sccs.iter() {
        let s0 = c.states[0];
        // A component is wholly inside or outside a successor-closed set.
        if within.is_some_and(|w| !w[s0]) {
            continue;
        }
        if !c.cyclic {
            if !snap.terminal[s0] {
                v[s0] = backup(snap, s0, alpha, &v, &mut pi[snap.sas(s0)], &mut qbuf);
            }
            continue;
        }
        local.enter(c);
        let res = (|| {
            let mut residual = f64::INFINITY;
            let mut tv = vec![0.0f64; c.states.len()];
            let mut previous: Option<Vec<f64>> = None;
            let mut cold_started = warm.is_none();
            for _sweep in 0..MAX_SWEEPS {
                let before: Vec<f64> = c.states.iter().flat_map(|&s| snap.sas(s)).map(|sa| pi[sa]).collect();
                if let Err(e) = eval_component(snap, c, &pi, alpha, &mut v, &local) {
                    let trapped = matches!(e, ModelError::Improper { .. } | ModelError::Singular(_));
                    match (&previous, alpha == 0.0) {
                        // α = 0 with (near-)zero-cost cycles — UAVs at one point — can make a
                        // tie broken by rounding close a loop. The previous policy was proper
                        // and optimal to rounding: keep it.
                        (Some(prev), true) if trapped => {
                            for (sa, &p) in c.states.iter().flat_map(|&s| snap.sas(s)).zip(prev) {
                                pi[sa] = p;
                            }
                            eval_component(snap, c, &pi, alpha, &mut v, &local)?;
                            return Ok(());
                        }
                        // α > 0: the Gibbs policy only loses support when the values run away
                        // (exp underflow of the exit actions) — the divergence described above.
                        (Some(_), false) if trapped => {
                            let value = c.states.iter().map(|&s| v[s]).fold(f64::INFINITY, f64::min);
                            return Err(ModelError::Diverged { alpha, states: c.states.clone(), value });
                        }
                        // An unusable warm start: start again from the uniform policy.
                        (None, _) if trapped && !cold_started => {
                            cold_started = true;
                            for s in &c.states {
                                let r = snap.sas(*s);
                                let k = r.len() as f64;
                                r.for_each(|sa| pi[sa] = 1.0 / k);
                            }
                            continue;
                        }
                        _ => return Err(e),
                    }
                }
                let vmin = c.states.iter().map(|&s| v[s]).fold(f64::INFINITY, f64::min);
                if alpha > 0.0 && vmin < -alpha * max_actions.ln() * MAX_EXPECTED_STEPS {
                    return Err(ModelError::Diverged { alpha, states: c.states.clone(), value: vmin });
                }
                // Policy improvement never raises a value. When it does, the evaluation was of a
                // nearly trapped policy — the numerical face of divergence.
                if alpha > 0.0 && previous.is_some() {
                    let rose = c.states.iter().enumerate().any(|(i, &s)| v[s] > tv[i] + 1e-8 * (1.0 + tv[i].abs()));
                    if rose {
                        let value = tv.iter().copied().fold(f64::INFINITY, f64::min);
                        return Err(ModelError::Diverged { alpha, states: c.states.clone(), value });
                    }
                }
                let vmax = c.states.iter().map(|&s| v[s].abs()).fold(0.0, f64::max);
                for (i, &s) in c.states.iter().enumerate() {
                    tv[i] = backup(snap, s, alpha, &v, &mut pi[snap.sas(s)], &mut qbuf);
                }
                residual = c.states.iter().enumerate().map(|(i, &s)| (tv[i] - v[s]).abs()).fold(0.0, f64::max);
                let unchanged = c.states.iter().flat_map(|&s| snap.sas(s)).zip(&before).all(|(sa, &p)| pi[sa] == p);
                previous = Some(before);
                if alpha == 0.0 && unchanged {
                    // `v` is already exactly the value of the returned policy: it was evaluated
                    // at this very policy, and backups do not write `v`.
                    return Ok(());
                }
                if residual <= 1e-14 * (1.0 + vmax) {
                    // Re-evaluate so that `v` is exactly the value of the returned policy.
                    eval_component(snap, c, &pi, alpha, &mut v, &local)?;
                    return Ok(());
                }
            }
            Err(ModelError::NotConverged { what: "soft policy iteration", iterations: MAX_SWEEPS, residual })
        })();
        local.leave(c);
        res?;
    }
    let j = match within {
        None => snap.mu.iter().map(|&(s, p)| p * v[s]).sum(),
        Some(_) => f64::NAN,
    };
    Ok(SoftSolution { alpha, v, pi, j })
}

/// The uniform policy over valid actions.
pub fn uniform(snap: &Snapshot) -> Vec<f64> {
    let mut pi = vec![0.0; snap.n_pairs()];
    for s in 0..snap.n_states {
        let r = snap.sas(s);
        let k = r.len() as f64;
        for sa in r {
            pi[sa] = 1.0 / k;
        }
    }
    pi
}

/// The greedy (most probable action, lowest index on ties) deterministic policy of `pi`.
pub fn greedy(snap: &Snapshot, pi: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; pi.len()];
    for s in 0..snap.n_states {
        let r = snap.sas(s);
        if r.is_empty() {
            continue;
        }
        let mut best = r.start;
        for sa in r {
            if pi[sa] > pi[best] {
                best = sa;
            }
        }
        out[best] = 1.0;
    }
    out
}
