//! ζ-gradients of the objective, exactly from the model and by central differences.
//!
//! The exact gradients all reduce to one pass over state–action pairs: with `W(s,a)` the
//! expected number of times `(s, a)` is taken and `U(s,a,o)` the visit-weighted value of the
//! successor of outcome `o`,
//!
//! `∇J = Σ_{s,a} Σ_o [ ∂p_o · (W c_o + γ U_o) + W p_o ∂c_o ] + (policy terms)`,
//!
//! i.e. the local derivative `∇ζ Σ_{s'} p_ζ(s'|s,a)(c_ζ + γV(s'))` with V frozen, weighted by
//! visits — the EnvPG theorem evaluated exactly.

use envpg_core::ModelMdp;

use crate::error::ModelError;
use crate::evaluate::{evaluate, mu_dense, visits};
use crate::horizon::HorizonSolution;
use crate::snapshot::Snapshot;
use crate::soft::SoftSolution;

/// Accumulates `Σ_{sa} Σ_o [∂p_o (W_sa c_o + γ U_o) + W_sa p_o ∂c_o]` into `grad`.
///
/// `w` is per pair, `u` per outcome of `snap`; states whose coefficients all vanish are skipped.
pub fn accumulate_local<M: ModelMdp + ?Sized>(
    mdp: &M,
    zeta: &[f64],
    snap: &Snapshot,
    w: &[f64],
    u: &[f64],
    grad: &mut [f64],
) {
    accumulate_with(mdp, zeta, snap, grad, |_, sa, o| (w[sa], u[o]));
}

/// [`accumulate_local`] with `(W_sa, U_o)` supplied per outcome by `coef(s, sa, o)`, using one
/// state-sized scratch instead of whole-model coefficient arrays.
fn accumulate_with<M: ModelMdp + ?Sized>(
    mdp: &M,
    zeta: &[f64],
    snap: &Snapshot,
    grad: &mut [f64],
    coef: impl Fn(usize, usize, usize) -> (f64, f64),
) {
    // Sized once for the largest state and written by index: pushes kept the loop's values
    // on the stack around their capacity checks (a profile's hottest lines).
    let widest = (0..snap.n_states).map(|s| snap.out_start[snap.sa_start[s + 1]] - snap.out_start[snap.sa_start[s]]);
    let widest = widest.max().unwrap_or(0);
    let mut cp = vec![0.0; widest];
    let mut cc = vec![0.0; widest];
    let (cost, prob, gamma) = (&snap.cost[..], &snap.prob[..], snap.gamma);
    for s in 0..snap.n_states {
        let pairs = snap.sas(s);
        if pairs.is_empty() {
            continue;
        }
        let (lo, hi) = (snap.out_start[pairs.start], snap.out_start[pairs.end]);
        let (cp, cc) = (&mut cp[..hi - lo], &mut cc[..hi - lo]);
        let mut any = false;
        for sa in pairs {
            for o in snap.outs(sa) {
                let (w, u) = coef(s, sa, o);
                let (p, c) = (w * cost[o] + gamma * u, w * prob[o]);
                cp[o - lo] = p;
                cc[o - lo] = c;
                any |= p != 0.0 || c != 0.0;
            }
        }
        if any {
            mdp.accumulate_state_grad(s, zeta, &prob[lo..hi], cp, cc, grad);
        }
    }
}

/// Exact `∇ζ J_H` of the soft-optimal SSP solution (the Gibbs corollary): visit counts from μ
/// under the Gibbs policy, then the local derivative with V frozen.
pub fn corollary_gradient<M: ModelMdp + ?Sized>(
    mdp: &M,
    zeta: &[f64],
    snap: &Snapshot,
    sol: &SoftSolution,
) -> Result<Vec<f64>, ModelError> {
    let rho = visits(snap, &sol.pi, &mu_dense(snap))?;
    Ok(policy_fixed_gradient(mdp, zeta, snap, &sol.pi, &sol.v, &rho))
}

/// `Σ_s ρ(s) Σ_a π(a|s) ∇ζ[Σ p (c + γV)]` for a policy held fixed.
fn policy_fixed_gradient<M: ModelMdp + ?Sized>(
    mdp: &M,
    zeta: &[f64],
    snap: &Snapshot,
    pi: &[f64],
    v: &[f64],
    rho: &[f64],
) -> Vec<f64> {
    let mut grad = vec![0.0; zeta.len()];
    accumulate_with(mdp, zeta, snap, &mut grad, |s, sa, o| {
        let w = rho[s] * pi[sa];
        (w, w * v[snap.next[o]])
    });
    grad
}

/// Exact `∇ζ J_H` of the finite-horizon solution: stage visits forward over the reachable
/// states, the hard tail's visits from the stage-H distribution, one local-derivative pass.
pub fn horizon_gradient<M: ModelMdp + ?Sized>(
    mdp: &M,
    zeta: &[f64],
    snap: &Snapshot,
    sol: &HorizonSolution,
) -> Result<Vec<f64>, ModelError> {
    let np = snap.n_pairs();
    let mut w = vec![0.0; np];
    let mut u = vec![0.0; snap.next.len()];
    let mut rho = mu_dense(snap);
    let mut rho_next = vec![0.0; snap.n_states];
    // The snapshot's tables as plain slices: read through `snap`, every store into `u` or
    // `rho_next` made the compiler reload their headers (it cannot rule out aliasing), and
    // this loop over every pair of the first stage was a profile's hottest.
    let (next, prob, terminal, gamma) = (&snap.next[..], &snap.prob[..], &snap.terminal[..], snap.gamma);
    let (sa_start, out_start) = (&snap.sa_start[..], &snap.out_start[..]);
    for (h, pi) in sol.pi.iter().enumerate() {
        let vnext = &sol.v[h + 1][..];
        rho_next.iter_mut().for_each(|r| *r = 0.0);
        let (u, w, rho_h, rho_to) = (&mut u[..], &mut w[..], &rho[..], &mut rho_next[..]);
        let mut at = 0;
        for &s in &sol.reach[h] {
            let pairs = sa_start[s]..sa_start[s + 1];
            let pi_s = &pi[at..at + pairs.len()];
            at += pairs.len();
            for (sa, &p) in pairs.zip(pi_s) {
                let wh = rho_h[s] * p;
                if wh == 0.0 {
                    continue;
                }
                w[sa] += wh;
                for o in out_start[sa]..out_start[sa + 1] {
                    let t = next[o];
                    u[o] += wh * vnext[t];
                    if !terminal[t] {
                        rho_to[t] += gamma * wh * prob[o];
                    }
                }
            }
        }
        std::mem::swap(&mut rho, &mut rho_next);
    }
    let rho_tail = visits(snap, &sol.tail.pi, &rho)?;
    for s in 0..snap.n_states {
        if rho_tail[s] == 0.0 {
            continue;
        }
        for sa in snap.sas(s) {
            let wt = rho_tail[s] * sol.tail.pi[sa];
            if wt == 0.0 {
                continue;
            }
            w[sa] += wt;
            for o in snap.outs(sa) {
                u[o] += wt * sol.tail.v[snap.next[o]];
            }
        }
    }
    let mut grad = vec![0.0; zeta.len()];
    accumulate_local(mdp, zeta, snap, &w, &u, &mut grad);
    Ok(grad)
}

/// A differentiable stochastic policy `π(a|s, ζ)` over the valid actions of each state.
pub trait ParamPolicy {
    /// Probabilities over `mdp.valid_actions(s)` (same order) at `zeta`.
    fn probs(&self, s: usize, zeta: &[f64], out: &mut [f64]);
    /// `∇ζ ln π(a_k|s, ζ)` for the `k`-th valid action of `s`.
    fn grad_log(&self, s: usize, k: usize, zeta: &[f64], out: &mut [f64]);
}

/// The per-pair probabilities of `policy` at `zeta`, in snapshot order.
pub fn policy_table<P: ParamPolicy>(snap: &Snapshot, policy: &P, zeta: &[f64]) -> Vec<f64> {
    let mut pi = vec![0.0; snap.n_pairs()];
    for s in 0..snap.n_states {
        let r = snap.sas(s);
        if !r.is_empty() {
            policy.probs(s, zeta, &mut pi[r]);
        }
    }
    pi
}

/// The right-hand side of the EnvPG theorem (Theorem 3.1, entropy form for α > 0), computed
/// exactly from the model:
///
/// `Σ_s ρ(s) Σ_a π(a|s) [∇ζ Q^H_{π,ζ̄}(s,a,ζ) + ∇ζ ln π(a|s,ζ) · Q^H_{π,ζ̄}(s,a,ζ̄)]`.
pub fn theorem_gradient<M: ModelMdp + ?Sized, P: ParamPolicy>(
    mdp: &M,
    zeta: &[f64],
    policy: &P,
    alpha: f64,
) -> Result<Vec<f64>, ModelError> {
    let snap = Snapshot::build(mdp, zeta);
    let pi = policy_table(&snap, policy, zeta);
    let val = evaluate(&snap, &pi, alpha)?;
    let rho = visits(&snap, &pi, &mu_dense(&snap))?;
    // Current-step copy: transitions and costs (V frozen at ζ̄).
    let mut grad = policy_fixed_gradient(mdp, zeta, &snap, &pi, &val.v, &rho);
    // Score term, plus the current-step entropy cost α ln π(a|s, ζ) inside Q^H.
    let d = zeta.len();
    let mut g = vec![0.0; d];
    for s in 0..snap.n_states {
        for (k, sa) in snap.sas(s).enumerate() {
            let w = rho[s] * pi[sa];
            if w == 0.0 {
                continue;
            }
            let q = snap.rbar[sa]
                + snap.gamma * snap.expect(sa, &val.v)
                + if alpha > 0.0 { alpha * pi[sa].ln() } else { 0.0 };
            policy.grad_log(s, k, zeta, &mut g);
            for i in 0..d {
                grad[i] += w * (q + alpha) * g[i];
            }
        }
    }
    Ok(grad)
}

/// Central differences of `f` at `zeta` with step `h` in every coordinate.
pub fn fd_gradient<E>(zeta: &[f64], h: f64, mut f: impl FnMut(&[f64]) -> Result<f64, E>) -> Result<Vec<f64>, E> {
    let mut z = zeta.to_vec();
    let mut g = vec![0.0; zeta.len()];
    for i in 0..zeta.len() {
        z[i] = zeta[i] + h;
        let fp = f(&z)?;
        z[i] = zeta[i] - h;
        let fm = f(&z)?;
        z[i] = zeta[i];
        g[i] = (fp - fm) / (2.0 * h);
    }
    Ok(g)
}
