//! [`PolicyTable`]: π_θk(·|s, ζ_k), evaluated lazily state by state within one iteration.
//!
//! Rollouts sample from this table, so a step costs a lookup, not a network pass; a state's
//! row is computed the first time it is needed, always as its own small batch (one column per
//! valid action). The arithmetic of a row therefore never depends on which other states were
//! evaluated, or in which order — every path (in-process, worker processes, the learner)
//! produces bitwise the same probabilities from the same weights.

use std::borrow::Cow;

use envpg_nn::Mlp;

use crate::features::Features;
use crate::nets::{ActionSets, Columns, softmax};

/// π over the valid actions of every state at one (θ, ζ), filled on demand.
#[derive(Debug, Clone)]
pub struct PolicyTable<'a> {
    actor: Cow<'a, Mlp<f32>>,
    features: Features,
    sets: ActionSets,
    zeta: Vec<f64>,
    probs: Vec<f64>,
    filled: Vec<bool>,
    cols: Columns,
    logits: Vec<f32>,
}

impl<'a> PolicyTable<'a> {
    /// The table of actor `actor` at design `zeta` (features centred there), borrowing the
    /// actor.
    pub fn new(actor: &'a Mlp<f32>, features: &Features, sets: &ActionSets, zeta: &[f64]) -> Self {
        Self::with(Cow::Borrowed(actor), features, sets, zeta)
    }

    /// The same with its own copy of the actor.
    pub fn owned(actor: &Mlp<f32>, features: &Features, sets: &ActionSets, zeta: &[f64]) -> PolicyTable<'static> {
        PolicyTable::with(Cow::Owned(actor.clone()), features, sets, zeta)
    }

    fn with(actor: Cow<'a, Mlp<f32>>, features: &Features, sets: &ActionSets, zeta: &[f64]) -> Self {
        Self {
            actor,
            features: features.centered(zeta),
            sets: sets.clone(),
            zeta: zeta.to_vec(),
            probs: vec![0.0; sets.n_pairs()],
            filled: vec![false; sets.n_states()],
            cols: Columns::default(),
            logits: Vec::new(),
        }
    }

    /// π(·|s) over the valid actions of `s`.
    pub fn of(&mut self, s: usize) -> &[f64] {
        let r = self.sets.first(s)..self.sets.first(s) + self.sets.of(s).len();
        if !self.filled[s] {
            self.cols.clear();
            for &a in self.sets.of(s) {
                self.cols.push(&self.features, s, a, &self.zeta, 0);
            }
            self.logits.clear();
            self.logits.resize(self.cols.len(), 0.0);
            self.actor.eval(&self.cols.inputs(), &mut self.logits);
            if !r.is_empty() {
                softmax(&self.logits, &mut self.probs[r.clone()]);
            }
            self.filled[s] = true;
        }
        &self.probs[r]
    }

    /// Every row, per pair (flattened as [`ActionSets`]).
    pub fn full(&mut self) -> &[f64] {
        for s in 0..self.sets.n_states() {
            self.of(s);
        }
        &self.probs
    }

    /// Per state, the index among its valid actions of the most probable one (lowest index on
    /// ties); `None` for a state without actions (terminal).
    fn argmax_indices(&mut self) -> Vec<Option<usize>> {
        self.full();
        (0..self.sets.n_states())
            .map(|s| {
                let first = self.sets.first(s);
                let p = &self.probs[first..first + self.sets.of(s).len()];
                (!p.is_empty()).then(|| {
                    let mut best = 0;
                    for (i, &x) in p.iter().enumerate() {
                        if x > p[best] {
                            best = i;
                        }
                    }
                    best
                })
            })
            .collect()
    }

    /// The most probable action of every state (lowest index on ties), one-hot per pair.
    pub fn greedy(&mut self) -> Vec<f64> {
        let actions = self.greedy_actions();
        self.sets.one_hot(&actions)
    }

    /// The same greedy policy as [`PolicyTable::greedy`], as one global action per state
    /// (0 for states without actions, which never act).
    pub fn greedy_actions(&mut self) -> Vec<usize> {
        let idx = self.argmax_indices();
        idx.into_iter().enumerate().map(|(s, best)| best.map_or(0, |i| self.sets.of(s)[i])).collect()
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use envpg_core::{Env, ParamMdp};
    use envpg_envs::uav::{GenerateSpec, UavNetwork, generate};

    use crate::{AcConfig, Learner};

    #[test]
    fn greedy_actions_name_the_one_hot_entries_of_the_greedy_policy() {
        let spec =
            GenerateSpec { name: "t".into(), n_users: 12, n_uav: 3, clusters: 2, side: 10.0, spread: 0.8, seed: 4 };
        let net = Arc::new(UavNetwork::new(generate(&spec).unwrap(), 0.9, 100.0).unwrap());
        let cfg = AcConfig { hidden: vec![8], ..Default::default() };
        let learner = Learner::new(net.clone(), net.feature_map(), cfg, 2, vec![2.0; 6]);
        let mut table = learner.policy_table();
        let (one_hot, actions) = (table.greedy(), table.greedy_actions());
        let sets = learner.action_sets();
        for s in 0..net.n_states() {
            let row = &one_hot[sets.first(s)..sets.first(s) + sets.of(s).len()];
            match row.iter().position(|&p| p == 1.0) {
                Some(i) => assert_eq!(actions[s], sets.of(s)[i], "state {s}"),
                None => assert!(net.is_terminal(s) && actions[s] == 0, "state {s}"),
            }
        }
        assert_eq!(sets.one_hot(&actions), one_hot, "and back");
    }
}
