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

    /// The most probable action of every state (lowest index on ties), one-hot per pair.
    pub fn greedy(&mut self) -> Vec<f64> {
        self.full();
        let mut out = vec![0.0; self.probs.len()];
        for s in 0..self.sets.n_states() {
            let first = self.sets.first(s);
            let p = &self.probs[first..first + self.sets.of(s).len()];
            if p.is_empty() {
                continue;
            }
            let mut best = 0;
            for (i, &x) in p.iter().enumerate() {
                if x > p[best] {
                    best = i;
                }
            }
            out[first + best] = 1.0;
        }
        out
    }
}
