//! Finite-horizon soft value iteration with a hard tail.
//!
//! The SSP form of soft value iteration diverges when α is large compared with the cost of
//! cycles, which limits how hot an anneal can start. A bounded horizon cannot diverge: the
//! soft policy is time-indexed over `H` stages, and after stage `H` the process follows the
//! hard-optimal (α = 0) SSP policy, whose values `V⁰` are the terminal values `V_H`. At low α
//! the loops this cuts off carry vanishing probability and the two forms agree.
//!
//! Only states reachable at stage `h` from μ are backed up at stage `h` (in the UAV network:
//! users at stage 0, UAVs after), so a stage costs a pass over the UAVs, not the users.

use crate::error::ModelError;
use crate::snapshot::Snapshot;
use std::sync::Arc;

use crate::soft::{SoftSolution, backup, solve_soft_within};

/// The solution of the finite-horizon problem at one temperature.
#[derive(Debug, Clone)]
pub struct HorizonSolution {
    /// Temperature.
    pub alpha: f64,
    /// States reachable at each stage `h = 0..H` (non-terminal).
    pub reach: Arc<Vec<Vec<usize>>>,
    /// Stage values `V_h`, `h = 0..=H` (`V_H` is the hard tail); entries of unreachable
    /// states are 0 for `h < H`.
    pub v: Vec<Vec<f64>>,
    /// Stage policies `π_h`, `h = 0..H`, over the pairs of the states reachable at stage `h`
    /// only: `pi[h]` lists the pairs of `reach[h][0]`, then of `reach[h][1]`, and so on. Dense
    /// per-pair tables would cost `H` × pairs per solve, almost all of it zeros when most
    /// states (the users) are reachable at stage 0 only.
    pub pi: Vec<Vec<f64>>,
    /// The hard SSP solution used after the horizon, solved only where the process can be
    /// after `H` stages (the states reachable from stage `H` on): elsewhere `v` is 0, `pi` the
    /// warm start (or uniform) and `j` NaN.
    pub tail: SoftSolution,
    /// `Σ μ V_0`.
    pub j: f64,
}

/// What the horizon form needs of a transition structure, whatever ζ: the states reachable at
/// each stage and the states the hard tail must solve. Cached in the [`Snapshot`].
#[derive(Debug)]
pub(crate) struct Stages {
    h: usize,
    pub(crate) reach: Arc<Vec<Vec<usize>>>,
    tail: Vec<bool>,
    /// For a state reachable at stage 0 only, and not in the tail, the offset of its first pair
    /// in the stage-0 policy; [`NOT_FIRST_ONLY`] for every other state. Such states (the users
    /// of the UAV network) are most of a large model, and the gradient reads their visits from
    /// the stage-0 policy directly instead of from model-sized per-pair tables.
    pub(crate) first_only: Vec<usize>,
    /// For every other state, the offsets of its first pair and first outcome in the compact
    /// per-pair and per-outcome tables the gradient accumulates in; `(pairs, outcomes)` of
    /// those tables in `slots`.
    pub(crate) slot: Vec<(usize, usize)>,
    pub(crate) slots: (usize, usize),
}

/// [`Stages::first_only`] of a state visited after stage 0, in the tail, or never.
pub(crate) const NOT_FIRST_ONLY: usize = usize::MAX;

impl Stages {
    fn new(snap: &Snapshot, h: usize) -> Self {
        let reach = reachable(snap, h);
        // The tail is entered at stage H: the successors of stage H − 1, and everything after.
        let mut tail = vec![false; snap.n_states];
        let mut todo: Vec<usize> = Vec::new();
        let mut enter = |t: usize, todo: &mut Vec<usize>| {
            if !snap.terminal[t] && !tail[t] {
                tail[t] = true;
                todo.push(t);
            }
        };
        let successors =
            |s: usize| snap.sas(s).flat_map(|sa| snap.outs(sa)).filter(|&o| snap.prob[o] > 0.0).map(|o| snap.next[o]);
        for &s in reach.last().into_iter().flatten() {
            for t in successors(s) {
                enter(t, &mut todo);
            }
        }
        while let Some(s) = todo.pop() {
            for t in successors(s) {
                enter(t, &mut todo);
            }
        }
        let mut first_only = vec![NOT_FIRST_ONLY; snap.n_states];
        let mut at = 0;
        for &s in reach.first().into_iter().flatten() {
            if !tail[s] {
                first_only[s] = at;
            }
            at += snap.sas(s).len();
        }
        for &s in reach.iter().skip(1).flatten() {
            first_only[s] = NOT_FIRST_ONLY;
        }
        let mut slot = vec![(NOT_FIRST_ONLY, NOT_FIRST_ONLY); snap.n_states];
        let mut slots = (0, 0);
        for s in (0..snap.n_states).filter(|&s| first_only[s] == NOT_FIRST_ONLY) {
            slot[s] = slots;
            let pairs = snap.sas(s);
            slots.0 += pairs.len();
            slots.1 += snap.out_start[pairs.end] - snap.out_start[pairs.start];
        }
        Self { h, reach: Arc::new(reach), tail, first_only, slot, slots }
    }

    /// The stages of `snap` for horizon `h`, from its cache when computed for the same `h`.
    pub(crate) fn of(snap: &Snapshot, h: usize) -> Arc<Self> {
        let cached = snap.stages.get_or_init(|| Arc::new(Self::new(snap, h)));
        if cached.h == h { Arc::clone(cached) } else { Arc::new(Self::new(snap, h)) }
    }
}

/// The non-terminal states reachable at stages `0..h` from μ.
pub fn reachable(snap: &Snapshot, h: usize) -> Vec<Vec<usize>> {
    let mut mark = vec![usize::MAX; snap.n_states];
    let mut cur: Vec<usize> = Vec::new();
    for &(s, p) in snap.mu.iter() {
        if p > 0.0 && !snap.terminal[s] && mark[s] != 0 {
            mark[s] = 0;
            cur.push(s);
        }
    }
    cur.sort_unstable();
    let mut out = Vec::with_capacity(h);
    for stage in 0..h {
        let mut next = Vec::new();
        for &s in &cur {
            for sa in snap.sas(s) {
                for o in snap.outs(sa) {
                    let t = snap.next[o];
                    if snap.prob[o] > 0.0 && !snap.terminal[t] && mark[t] != stage + 1 {
                        mark[t] = stage + 1;
                        next.push(t);
                    }
                }
            }
        }
        next.sort_unstable();
        out.push(std::mem::replace(&mut cur, next));
    }
    out
}

/// Solves the `h`-stage soft problem at `alpha` with the hard-optimal tail.
pub fn solve_horizon(
    snap: &Snapshot,
    alpha: f64,
    h: usize,
    tail_warm: Option<&[f64]>,
) -> Result<HorizonSolution, ModelError> {
    solve_horizon_tail(snap, alpha, h, tail_warm, true)
}

/// [`solve_horizon`], solving the hard tail only where it is entered (`restrict`) or on every
/// state (the reference the restriction is tested against).
fn solve_horizon_tail(
    snap: &Snapshot,
    alpha: f64,
    h: usize,
    tail_warm: Option<&[f64]>,
    restrict: bool,
) -> Result<HorizonSolution, ModelError> {
    if h == 0 {
        return Err(ModelError::Invalid("horizon must be at least 1".into()));
    }
    let stages = Stages::of(snap, h);
    let tail = solve_soft_within(snap, 0.0, tail_warm, restrict.then_some(&stages.tail[..]))?;
    let reach = Arc::clone(&stages.reach);
    let mut v: Vec<Vec<f64>> = (0..=h).map(|_| vec![0.0; snap.n_states]).collect();
    v[h].copy_from_slice(&tail.v);
    let mut pis: Vec<Vec<f64>> =
        reach.iter().map(|states| vec![0.0; states.iter().map(|&s| snap.sas(s).len()).sum()]).collect();
    let mut qbuf = Vec::new();
    for stage in (0..h).rev() {
        let (head, rest) = v.split_at_mut(stage + 1);
        let (cur, next) = (&mut head[stage], &rest[0]);
        let mut at = 0;
        for &s in &reach[stage] {
            let k = snap.sas(s).len();
            cur[s] = backup(snap, s, alpha, next, &mut pis[stage][at..at + k], &mut qbuf);
            at += k;
        }
    }
    let j = snap.mu.iter().map(|&(s, p)| p * v[0][s]).sum();
    Ok(HorizonSolution { alpha, reach, v, pi: pis, tail, j })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Solving the tail only where the process can be after H stages changes no bit of the
    /// values and policies of the stages, nor of the tail where it is entered.
    #[test]
    fn a_tail_restricted_to_where_it_is_entered_changes_no_bit() {
        for kappa in [1.0, 0.85] {
            let env = envpg_envs::registry().load("uav271", &[("kappa".into(), kappa)]).unwrap();
            let model = env.model().unwrap();
            let zeta = model.heuristic_design().unwrap();
            let snap = Snapshot::build(model, &zeta);
            let h = model.oracle_hints().horizon;
            for alpha in [0.05, 2.0, 300.0] {
                let fast = solve_horizon_tail(&snap, alpha, h, None, true).unwrap();
                let full = solve_horizon_tail(&snap, alpha, h, None, false).unwrap();
                assert_eq!(fast.j.to_bits(), full.j.to_bits(), "kappa {kappa}, alpha {alpha}");
                // Stage values before the tail, and every stage policy.
                assert!(fast.v[..h] == full.v[..h], "kappa {kappa}, alpha {alpha}: stage values differ");
                assert!(fast.pi == full.pi, "kappa {kappa}, alpha {alpha}: stage policies differ");
                let tail = &Stages::of(&snap, h).tail;
                assert!(tail.iter().any(|&t| t) && tail.iter().any(|&t| !t), "the tail is a proper part");
                for s in (0..snap.n_states).filter(|&s| tail[s]) {
                    assert_eq!(fast.v[h][s].to_bits(), full.v[h][s].to_bits());
                    assert_eq!(fast.tail.v[s].to_bits(), full.tail.v[s].to_bits());
                    assert_eq!(fast.tail.pi[snap.sas(s)], full.tail.pi[snap.sas(s)]);
                }
            }
        }
    }
}
