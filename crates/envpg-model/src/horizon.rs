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
use crate::soft::{SoftSolution, backup, solve_soft};

/// The solution of the finite-horizon problem at one temperature.
#[derive(Debug, Clone)]
pub struct HorizonSolution {
    /// Temperature.
    pub alpha: f64,
    /// States reachable at each stage `h = 0..H` (non-terminal).
    pub reach: Vec<Vec<usize>>,
    /// Stage values `V_h`, `h = 0..=H` (`V_H` is the hard tail); entries of unreachable
    /// states are 0 for `h < H`.
    pub v: Vec<Vec<f64>>,
    /// Stage policies `π_h` per pair, `h = 0..H` (zero on unreachable states).
    pub pi: Vec<Vec<f64>>,
    /// The hard SSP solution used after the horizon.
    pub tail: SoftSolution,
    /// `Σ μ V_0`.
    pub j: f64,
}

/// The non-terminal states reachable at stages `0..h` from μ.
pub fn reachable(snap: &Snapshot, h: usize) -> Vec<Vec<usize>> {
    let mut mark = vec![usize::MAX; snap.n_states];
    let mut cur: Vec<usize> = Vec::new();
    for &(s, p) in &snap.mu {
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
    if h == 0 {
        return Err(ModelError::Invalid("horizon must be at least 1".into()));
    }
    let tail = solve_soft(snap, 0.0, tail_warm)?;
    let reach = reachable(snap, h);
    let mut v = vec![vec![0.0; snap.n_states]; h + 1];
    v[h].copy_from_slice(&tail.v);
    let mut pis = vec![vec![0.0; snap.n_pairs()]; h];
    let mut qbuf = Vec::new();
    for stage in (0..h).rev() {
        let (head, rest) = v.split_at_mut(stage + 1);
        let (cur, next) = (&mut head[stage], &rest[0]);
        for &s in &reach[stage] {
            cur[s] = backup(snap, s, alpha, next, &mut pis[stage], &mut qbuf);
        }
    }
    let j = snap.mu.iter().map(|&(s, p)| p * v[0][s]).sum();
    Ok(HorizonSolution { alpha, reach, v, pi: pis, tail, j })
}
