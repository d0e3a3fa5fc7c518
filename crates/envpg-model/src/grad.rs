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
use crate::horizon::{HorizonSolution, NOT_FIRST_ONLY, Stages};
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
    accumulate_with(mdp, zeta, snap, grad, |_| |sa, o| (w[sa], u[o]));
}

/// [`accumulate_local`] with `(W_sa, U_o)` supplied per outcome by `coef(s)(sa, o)`, using one
/// state-sized scratch instead of whole-model coefficient arrays. `coef(s)` reads what it needs
/// of state `s` once: read per outcome, the stores into the scratch kept the compiler from
/// hoisting those loads out of the loop.
fn accumulate_with<M: ModelMdp + ?Sized, C: Fn(usize, usize) -> (f64, f64)>(
    mdp: &M,
    zeta: &[f64],
    snap: &Snapshot,
    grad: &mut [f64],
    coef: impl Fn(usize) -> C,
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
        let coef = coef(s);
        for sa in pairs {
            for o in snap.outs(sa) {
                let (w, u) = coef(sa, o);
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
    accumulate_with(mdp, zeta, snap, &mut grad, |s| {
        let rho_s = rho[s];
        move |sa, o| {
            let w = rho_s * pi[sa];
            (w, w * v[snap.next[o]])
        }
    });
    grad
}

/// Exact `∇ζ J_H` of the finite-horizon solution: stage visits forward over the reachable
/// states, the hard tail's visits from the stage-H distribution, one local-derivative pass.
///
/// States visited at stage 0 only (the users of the UAV network) get their visits `W = μ π₀` and
/// successor terms `U = W V₁` straight from the stage-0 policy in the last pass, the same
/// operations on the same values as through the per-pair tables the other states accumulate in,
/// so the same bits at a fraction of the memory traffic.
pub fn horizon_gradient<M: ModelMdp + ?Sized>(
    mdp: &M,
    zeta: &[f64],
    snap: &Snapshot,
    sol: &HorizonSolution,
) -> Result<Vec<f64>, ModelError> {
    let stages = Stages::of(snap, sol.pi.len());
    let (first_only, slot) = (&stages.first_only[..], &stages.slot[..]);
    // Visits and successor terms of the other states, in compact tables: pair `sa` of state
    // `s` at `slot[s].0 + (sa − first pair of s)`, its outcome `o` at `slot[s].1 + (o − first
    // outcome of s)`.
    let mut w = vec![0.0; stages.slots.0];
    let mut u = vec![0.0; stages.slots.1];
    let mu = mu_dense(snap);
    let mut rho = mu.clone();
    let mut rho_next = vec![0.0; snap.n_states];
    // The snapshot's tables as plain slices: read through `snap`, every store into `u` or
    // `rho_next` made the compiler reload their headers (it cannot rule out aliasing), and
    // this loop over every pair of the first stage was a profile's hottest.
    let (next, prob, terminal, gamma) = (&snap.next[..], &snap.prob[..], &snap.terminal[..], snap.gamma);
    let (sa_start, out_start) = (&snap.sa_start[..], &snap.out_start[..]);
    for (h, pi) in sol.pi.iter().enumerate() {
        let vnext = &sol.v[h + 1][..];
        // `rho_next` held the distribution of stage h − 1 (μ for h = 1), nonzero only at the
        // states reachable then (every mass added lands on a positive-probability successor or
        // adds zero): zero those entries, not the whole model.
        match h {
            0 => {}
            1 => snap.mu.iter().for_each(|&(s, _)| rho_next[s] = 0.0),
            _ => sol.reach[h - 1].iter().for_each(|&s| rho_next[s] = 0.0),
        }
        let (u, w, rho_h, rho_to) = (&mut u[..], &mut w[..], &rho[..], &mut rho_next[..]);
        let mut at = 0;
        for &s in &sol.reach[h] {
            let pairs = sa_start[s]..sa_start[s + 1];
            let pi_s = &pi[at..at + pairs.len()];
            at += pairs.len();
            // A state seen at stage 0 only keeps no tables: its terms are read from π₀ at the end.
            let untabled = h == 0 && first_only[s] != NOT_FIRST_ONLY;
            let (ws, us) = (slot[s].0.wrapping_sub(pairs.start), slot[s].1.wrapping_sub(out_start[pairs.start]));
            for (sa, &p) in pairs.zip(pi_s) {
                let wh = rho_h[s] * p;
                if wh == 0.0 {
                    continue;
                }
                if !untabled {
                    w[ws.wrapping_add(sa)] += wh;
                }
                for o in snap.outs(sa) {
                    let t = next[o];
                    if !untabled {
                        u[us.wrapping_add(o)] += wh * vnext[t];
                    }
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
        let pairs = snap.sas(s);
        let (ws, us) = (slot[s].0.wrapping_sub(pairs.start), slot[s].1.wrapping_sub(out_start[pairs.start]));
        for sa in pairs {
            let wt = rho_tail[s] * sol.tail.pi[sa];
            if wt == 0.0 {
                continue;
            }
            w[ws.wrapping_add(sa)] += wt;
            for o in snap.outs(sa) {
                u[us.wrapping_add(o)] += wt * sol.tail.v[snap.next[o]];
            }
        }
    }
    let mut grad = vec![0.0; zeta.len()];
    let (pi0, v1) = (sol.pi.first().map_or(&[][..], |p| &p[..]), sol.v.get(1).map_or(&[][..], |v| &v[..]));
    let (w, u) = (&w[..], &u[..]);
    accumulate_with(mdp, zeta, snap, &mut grad, |s| {
        let (first, at, mu_s) = (sa_start[s], first_only[s], mu[s]);
        // Offsets from a pair and an outcome of `s` to their entries in the tables (or in π₀).
        let (ws, us) = (slot[s].0.wrapping_sub(first), slot[s].1.wrapping_sub(out_start[first]));
        let pi0s = at.wrapping_sub(first);
        move |sa, o| match at {
            NOT_FIRST_ONLY => (w[ws.wrapping_add(sa)], u[us.wrapping_add(o)]),
            // What the tables would hold: one addition to zero each, or nothing when W = 0.
            _ => {
                let wh = mu_s * pi0[pi0s.wrapping_add(sa)];
                if wh == 0.0 { (0.0, 0.0) } else { (0.0 + wh, 0.0 + wh * v1[next[o]]) }
            }
        }
    });
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::horizon::solve_horizon;
    use envpg_core::ParamMdp;

    /// `∇ζ J_H` of the finite-horizon form with every state's visits and successor terms
    /// accumulated in whole-model per-pair and per-outcome tables, and every stage
    /// distribution zeroed in full: the direct reading of the definition.
    fn horizon_gradient_dense<M: ModelMdp + ?Sized>(
        mdp: &M,
        zeta: &[f64],
        snap: &Snapshot,
        sol: &HorizonSolution,
    ) -> Vec<f64> {
        let mut w = vec![0.0; snap.n_pairs()];
        let mut u = vec![0.0; snap.next.len()];
        let mut rho = mu_dense(snap);
        for (h, pi) in sol.pi.iter().enumerate() {
            let mut rho_to = vec![0.0; snap.n_states];
            let mut at = 0;
            for &s in &sol.reach[h] {
                for sa in snap.sas(s) {
                    let wh = rho[s] * pi[at];
                    at += 1;
                    if wh == 0.0 {
                        continue;
                    }
                    w[sa] += wh;
                    for o in snap.outs(sa) {
                        let t = snap.next[o];
                        u[o] += wh * sol.v[h + 1][t];
                        if !snap.terminal[t] {
                            rho_to[t] += snap.gamma * wh * snap.prob[o];
                        }
                    }
                }
            }
            rho = rho_to;
        }
        let rho_tail = visits(snap, &sol.tail.pi, &rho).unwrap();
        for s in 0..snap.n_states {
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
        grad
    }

    /// Reading the visits of the states seen at stage 0 only from the stage-0 policy, keeping
    /// the other states' terms in compact tables and zeroing only the reached entries of the
    /// stage distributions changes no bit of the gradient: on the UAV network (users at stage
    /// 0 only), flpo, aac, and random MDPs whose initial states are visited again later.
    #[test]
    fn the_horizon_gradient_gives_the_bits_of_whole_model_tables() {
        // Whether some initial state is visited again (after stage 0 or in the tail).
        let check = |model: &dyn ModelMdp, zeta: &[f64], h: usize, what: &str| -> bool {
            let snap = Snapshot::build(model, zeta);
            let stages = Stages::of(&snap, h);
            for alpha in [0.05, 2.0, 300.0] {
                let sol = solve_horizon(&snap, alpha, h, None).unwrap();
                let fast = horizon_gradient(model, zeta, &snap, &sol).unwrap();
                let dense = horizon_gradient_dense(model, zeta, &snap, &sol);
                let bits = |g: &[f64]| g.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&fast), bits(&dense), "{what}, alpha {alpha}");
                assert!(dense.iter().any(|&g| g != 0.0), "{what}: a gradient that could differ");
            }
            stages.reach[0].iter().any(|&s| stages.first_only[s] == NOT_FIRST_ONLY)
        };
        let cases: [(&str, &[(&str, f64)]); 5] = [
            ("uav271", &[("kappa", 1.0)]),
            ("uav271", &[("kappa", 0.85)]),
            ("flpo-n10m4", &[]),
            ("flpo-n10m4", &[("kappa", 0.9)]),
            ("aac1800", &[]),
        ];
        for (name, params) in cases {
            let params: Vec<(String, f64)> = params.iter().map(|&(k, v)| (k.to_string(), v)).collect();
            let env = envpg_envs::registry().load(name, &params).unwrap();
            let model = env.model().unwrap();
            let zeta = model.random_design(&mut envpg_core::Streams::new(1).stream(envpg_core::Purpose::Zeta0, 0, 0));
            check(model, &zeta, model.oracle_hints().horizon, &format!("{name} {params:?}"));
        }
        let mut revisited = 0;
        for seed in 0..8 {
            let mdp = crate::random::RandomMdp::new(seed, 7, 3, 3, 1.0, true);
            let zeta = mdp.random_design(&mut envpg_core::Streams::new(seed).stream(envpg_core::Purpose::Zeta0, 0, 0));
            revisited += usize::from(check(&mdp, &zeta, 4, &format!("random MDP {seed}")));
        }
        assert!(revisited > 0, "some random MDP visits an initial state again");
    }
}
