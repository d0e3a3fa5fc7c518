//! [`Snapshot`]: the whole model at one ζ, as flat tables, plus its strongly connected components.
//!
//! Solvers work on snapshots so each transition is computed once per ζ. The SCC decomposition
//! lets them solve the MDP component by component in topological order: in the UAV network
//! every user is its own component and only the M UAVs form a cycle, so an exact evaluation is
//! one M×M solve plus a pass over the users.

use std::sync::{Arc, OnceLock};

use envpg_core::ModelMdp;

/// The model of an MDP at one ζ.
#[derive(Debug, Clone)]
pub struct Snapshot {
    /// Number of states.
    pub n_states: usize,
    /// Number of global actions.
    pub n_actions: usize,
    /// Discount factor.
    pub gamma: f64,
    /// Initial distribution μ as `(state, prob)`.
    pub mu: Arc<Vec<(usize, f64)>>,
    /// Terminal flags.
    pub terminal: Arc<Vec<bool>>,
    /// `sa_start[s]..sa_start[s+1]` are the state–action pairs of `s`.
    pub sa_start: Arc<Vec<usize>>,
    /// Global action of each state–action pair.
    pub sa_action: Arc<Vec<usize>>,
    /// `out_start[sa]..out_start[sa+1]` are the outcomes of pair `sa`.
    pub out_start: Arc<Vec<usize>>,
    /// Successor state of each outcome.
    pub next: Arc<Vec<usize>>,
    /// Probability of each outcome.
    pub prob: Vec<f64>,
    /// Cost of each outcome.
    pub cost: Vec<f64>,
    /// Expected immediate cost `Σ p c` of each pair.
    pub rbar: Vec<f64>,
    /// Strongly connected components in reverse topological order (successors first).
    pub sccs: Arc<Vec<Scc>>,
    /// The finite-horizon stages of this transition structure, computed on first use and
    /// shared, like `sccs`, by snapshots built like this one.
    pub(crate) stages: Arc<OnceLock<Arc<crate::horizon::Stages>>>,
    /// Every pair has exactly one outcome (every pair of a deterministic model): outcome `sa`
    /// is pair `sa`'s, and [`Snapshot::outs`] needs no look-up.
    single: bool,
}

/// One strongly connected component of the transition graph.
#[derive(Debug, Clone)]
pub struct Scc {
    /// Its states.
    pub states: Vec<usize>,
    /// Whether it contains a cycle (more than one state, or a self-loop).
    pub cyclic: bool,
}

impl Snapshot {
    /// Expands `mdp` at `zeta`.
    pub fn build<M: ModelMdp + ?Sized>(mdp: &M, zeta: &[f64]) -> Self {
        Self::build_like(mdp, zeta, None)
    }

    /// Expands `mdp` at `zeta`, reusing the component decomposition of `like` — a snapshot of
    /// the same model — when the transition structure is unchanged (the usual case between
    /// nearby designs).
    pub fn build_like<M: ModelMdp + ?Sized>(mdp: &M, zeta: &[f64], like: Option<&Snapshot>) -> Self {
        let n = mdp.n_states();
        // μ, the terminal states and the valid actions do not depend on ζ: share them.
        let (mu, terminal, sa_start, sa_action) = match like {
            Some(l) => (Arc::clone(&l.mu), Arc::clone(&l.terminal), Arc::clone(&l.sa_start), Arc::clone(&l.sa_action)),
            None => {
                let mut sa_start = Vec::with_capacity(n + 1);
                let mut sa_action = Vec::new();
                for s in 0..n {
                    sa_start.push(sa_action.len());
                    sa_action.extend_from_slice(mdp.valid_actions(s));
                }
                sa_start.push(sa_action.len());
                let terminal = (0..n).map(|s| mdp.is_terminal(s)).collect();
                (Arc::new(mdp.initial_distribution()), Arc::new(terminal), Arc::new(sa_start), Arc::new(sa_action))
            }
        };
        let mut snap = Snapshot {
            n_states: n,
            n_actions: mdp.n_actions(),
            gamma: mdp.gamma(),
            mu,
            terminal,
            sa_start,
            sa_action,
            out_start: Default::default(),
            next: Default::default(),
            prob: Vec::with_capacity(like.map_or(0, |l| l.next.len())),
            cost: Vec::with_capacity(like.map_or(0, |l| l.next.len())),
            rbar: Vec::with_capacity(like.map_or(0, |l| l.rbar.len())),
            sccs: Arc::new(Vec::new()),
            stages: Default::default(),
            single: false,
        };
        // A model whose successors do not depend on ζ fills in only the new probabilities and
        // costs: the successors and outcome counts are `like`'s.
        let fixed = like.filter(|_| mdp.outcome_values(zeta, &mut snap.prob, &mut snap.cost));
        if let Some(l) = fixed {
            assert_eq!(snap.prob.len(), l.next.len(), "outcome_values: one probability per outcome");
            assert_eq!(snap.cost.len(), l.next.len(), "outcome_values: one cost per outcome");
            (snap.out_start, snap.next) = (Arc::clone(&l.out_start), Arc::clone(&l.next));
            snap.single = l.single;
        } else {
            snap.prob.clear();
            snap.cost.clear();
            let mut out_start = Vec::with_capacity(like.map_or(1, |l| l.out_start.len()));
            let mut next = Vec::with_capacity(like.map_or(0, |l| l.next.len()));
            out_start.push(0);
            // The running outcome counts a model appends per action are `out_start` itself.
            mdp.all_outcomes(zeta, &mut next, &mut snap.prob, &mut snap.cost, &mut out_start);
            assert_eq!(out_start.len(), snap.sa_action.len() + 1, "one end per valid action");
            snap.single = out_start.iter().enumerate().fold(true, |one, (sa, &o)| one & (o == sa));
            (snap.out_start, snap.next) = (Arc::new(out_start), Arc::new(next));
        }
        let (prob, cost) = (&snap.prob, &snap.cost);
        // A pair with one outcome sums that one term: the same `sum`, without the loop around it.
        if snap.single {
            snap.rbar.extend(prob.iter().zip(cost).map(|(p, c)| std::iter::once(p * c).sum::<f64>()));
        } else {
            snap.rbar.extend(snap.out_start.windows(2).map(|w| match w[1] - w[0] {
                1 => std::iter::once(prob[w[0]] * cost[w[0]]).sum::<f64>(),
                _ => (w[0]..w[1]).map(|o| prob[o] * cost[o]).sum::<f64>(),
            }));
        }
        let same_support = |l: &Snapshot| {
            (Arc::ptr_eq(&l.next, &snap.next) || (l.out_start == snap.out_start && l.next == snap.next))
                // Without the early exit of `all`, this loop vectorizes.
                && l.prob.iter().zip(&snap.prob).fold(true, |same, (a, b)| same & ((*a > 0.0) == (*b > 0.0)))
        };
        match like {
            Some(l) if same_support(l) => {
                snap.sccs = Arc::clone(&l.sccs);
                snap.stages = Arc::clone(&l.stages);
            }
            _ => snap.sccs = Arc::new(tarjan(&snap)),
        }
        snap
    }

    /// The state–action pair indices of `s`.
    #[inline]
    pub fn sas(&self, s: usize) -> std::ops::Range<usize> {
        self.sa_start[s]..self.sa_start[s + 1]
    }

    /// The outcome indices of pair `sa`.
    #[inline]
    pub fn outs(&self, sa: usize) -> std::ops::Range<usize> {
        if self.single { sa..sa + 1 } else { self.out_start[sa]..self.out_start[sa + 1] }
    }

    /// `Σ_o p_o V(next_o)` for pair `sa`.
    #[inline]
    pub fn expect(&self, sa: usize, v: &[f64]) -> f64 {
        self.outs(sa).map(|o| self.prob[o] * v[self.next[o]]).sum()
    }

    /// The number of state–action pairs.
    pub fn n_pairs(&self) -> usize {
        self.sa_action.len()
    }

    /// The state of each state–action pair.
    pub fn pair_states(&self) -> Vec<usize> {
        let mut out = vec![0; self.n_pairs()];
        for s in 0..self.n_states {
            for sa in self.sas(s) {
                out[sa] = s;
            }
        }
        out
    }
}

/// Iterative Tarjan over edges with positive probability; components come out sinks first.
fn tarjan(snap: &Snapshot) -> Vec<Scc> {
    let n = snap.n_states;
    // Deduplicated successor lists in CSR form.
    let mut adj_start = Vec::with_capacity(n + 1);
    let mut adj = Vec::new();
    let mut mark = vec![usize::MAX; n];
    for s in 0..n {
        adj_start.push(adj.len());
        let lo = snap.out_start[snap.sa_start[s]];
        let hi = snap.out_start[snap.sa_start[s + 1]];
        for o in lo..hi {
            let t = snap.next[o];
            if snap.prob[o] > 0.0 && mark[t] != s {
                mark[t] = s;
                adj.push(t);
            }
        }
    }
    adj_start.push(adj.len());
    const UNSEEN: usize = usize::MAX;
    let mut index = vec![UNSEEN; n];
    let mut low = vec![0; n];
    let mut on_stack = vec![false; n];
    let mut stack = Vec::new();
    let mut out = Vec::new();
    let mut counter = 0;
    // Call stack of (node, next successor position).
    let mut call: Vec<(usize, usize)> = Vec::new();
    for root in 0..n {
        if index[root] != UNSEEN {
            continue;
        }
        index[root] = counter;
        low[root] = counter;
        counter += 1;
        stack.push(root);
        on_stack[root] = true;
        call.push((root, adj_start[root]));
        while let Some(&mut (v, ref mut pos)) = call.last_mut() {
            if *pos < adj_start[v + 1] {
                let w = adj[*pos];
                *pos += 1;
                if index[w] == UNSEEN {
                    index[w] = counter;
                    low[w] = counter;
                    counter += 1;
                    stack.push(w);
                    on_stack[w] = true;
                    call.push((w, adj_start[w]));
                } else if on_stack[w] {
                    low[v] = low[v].min(index[w]);
                }
            } else {
                call.pop();
                if let Some(&(u, _)) = call.last() {
                    low[u] = low[u].min(low[v]);
                }
                if low[v] == index[v] {
                    let mut states = Vec::new();
                    loop {
                        let w = stack.pop().expect("tarjan stack");
                        on_stack[w] = false;
                        states.push(w);
                        if w == v {
                            break;
                        }
                    }
                    let cyclic = if states.len() > 1 {
                        states.sort_unstable();
                        true
                    } else {
                        adj[adj_start[v]..adj_start[v + 1]].contains(&v)
                    };
                    out.push(Scc { states, cyclic });
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Built like a snapshot of another design, a snapshot holds a fresh build's tables bit for
    /// bit; where the model fills in values only (the UAV network at κ = 1) it shares the
    /// other's successors instead of expanding them again.
    #[test]
    fn a_snapshot_built_like_another_holds_a_fresh_builds_bits() {
        for (kappa, shared) in [(1.0, true), (0.85, false)] {
            let env = envpg_envs::registry().load("uav271", &[("kappa".into(), kappa)]).unwrap();
            let model = env.model().unwrap();
            let zeta = model.heuristic_design().unwrap();
            let other: Vec<f64> = zeta.iter().map(|z| z + 0.3).collect();
            let like = Snapshot::build(model, &other);
            let (a, b) = (Snapshot::build_like(model, &zeta, Some(&like)), Snapshot::build(model, &zeta));
            let bits = |x: &[f64]| x.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!((&a.next, &a.out_start), (&b.next, &b.out_start), "kappa {kappa}");
            assert_eq!(bits(&a.prob), bits(&b.prob), "kappa {kappa}");
            assert_eq!(bits(&a.cost), bits(&b.cost), "kappa {kappa}");
            assert_eq!(bits(&a.rbar), bits(&b.rbar), "kappa {kappa}");
            assert_eq!(a.single, b.single);
            assert_eq!(a.single, kappa == 1.0, "one outcome per pair exactly at kappa 1");
            assert_eq!(Arc::ptr_eq(&a.next, &like.next), shared, "kappa {kappa}");
            // Far apart at κ < 1, some deviations' probabilities underflow: the support differs.
            assert!(!shared || Arc::ptr_eq(&a.sccs, &like.sccs), "kappa {kappa}: same components");
        }
    }
}
