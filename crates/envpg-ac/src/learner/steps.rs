//! The network steps of an update: the critic's TD steps on targets from the Polyak-averaged
//! critic, and the actor's step (Gibbs fit or policy gradient).

use envpg_core::Purpose;
use rand::RngExt;

use super::{ActorPass, EVAL_CHUNK, Flat, Learner};
use crate::nets::{Columns, softmax};
use crate::rollout::Episode;
use crate::table::PolicyTable;

impl Learner {
    /// ln π_θk(a_i|s_i, ζ_pert,i) for every transition (the entropy term of the TD targets).
    pub(super) fn log_pi_at_pert(&mut self, f: &Flat) -> Vec<f64> {
        let d = self.zeta.len();
        let mut out = Vec::with_capacity(f.s.len());
        let (mut cols, mut logits, mut probs) = (Columns::default(), Vec::new(), Vec::new());
        for lo in (0..f.s.len()).step_by(EVAL_CHUNK) {
            let hi = (lo + EVAL_CHUNK).min(f.s.len());
            cols.clear();
            for i in lo..hi {
                for &a in self.sets.of(f.s[i]) {
                    cols.push(&self.features, f.s[i], a, &f.zeta[i * d..(i + 1) * d], i as u32);
                }
            }
            self.actor.values(&cols, &mut logits);
            let mut c = 0;
            for i in lo..hi {
                let acts = self.sets.of(f.s[i]);
                out.push(ln_pi_taken(acts, f.a[i], &logits[c..c + acts.len()], &mut probs));
                c += acts.len();
            }
        }
        out
    }

    /// `V⁻(s') = Σ_a' π_θk(a'|s', ζ_k) Q_φ⁻(s', a', ζ_k)` for the given states.
    pub(super) fn target_values(&mut self, states: &[usize], table: &mut PolicyTable) -> Vec<f64> {
        let mut out = Vec::with_capacity(states.len());
        let (mut cols, mut q) = (Columns::default(), Vec::new());
        for chunk in states.chunks(EVAL_CHUNK) {
            cols.clear();
            for &s in chunk {
                for &a in self.sets.of(s) {
                    cols.push(&self.features, s, a, &self.zeta, 0);
                }
            }
            self.target.values(&cols, &mut q);
            let mut c = 0;
            out.extend(chunk.iter().map(|&s| {
                let p = table.of(s);
                let v: f64 = p.iter().zip(&q[c..c + p.len()]).map(|(p, q)| p * *q as f64).sum();
                c += p.len();
                v
            }));
        }
        out
    }

    /// Minibatch indices for learner purpose `(k, j)`: `min(N, n)` distinct transitions of the
    /// iteration's buffer (all of them, shuffled, when the buffer is smaller than N).
    pub(super) fn minibatch(&self, n: usize, j: u64) -> Vec<usize> {
        let mut rng = self.streams.stream(Purpose::Minibatch, self.k, j);
        let take = self.cfg.batch.min(n);
        // Partial Fisher–Yates: the first `take` entries are a uniform sample without replacement.
        let mut idx: Vec<usize> = (0..n).collect();
        for i in 0..take {
            let j = rng.random_range(i..n);
            idx.swap(i, j);
        }
        idx.truncate(take);
        idx
    }

    /// One TD step of the critic and a Polyak update of the target; returns the loss.
    pub(super) fn critic_step(&mut self, f: &Flat, ln_pi: &[f64], table: &mut PolicyTable, step: usize) -> f64 {
        let d = self.zeta.len();
        let idx = self.minibatch(f.s.len(), step as u64);
        // Distinct non-terminal successors, in first-seen order.
        let mut next_states: Vec<usize> = Vec::new();
        for &i in &idx {
            let s2 = f.s2[i];
            if !self.sets.terminal(s2) && !next_states.contains(&s2) {
                next_states.push(s2);
            }
        }
        let v = self.target_values(&next_states, table);
        let mut cols = Columns::with_capacity(&self.features, idx.len());
        let mut y = Vec::with_capacity(idx.len());
        for &i in &idx {
            let s2 = f.s2[i];
            let boot = if self.sets.terminal(s2) {
                0.0
            } else {
                v[next_states.iter().position(|&x| x == s2).expect("listed")]
            };
            y.push(f.cost[i] + self.alpha * ln_pi[i] + self.gamma * boot);
            cols.push(&self.features, f.s[i], f.a[i], &f.zeta[i * d..(i + 1) * d], i as u32);
        }
        let mut q = Vec::new();
        self.critic.eval(&cols, &mut q);
        let n = idx.len() as f64;
        let mut loss = 0.0;
        let dq: Vec<f32> = q
            .iter()
            .zip(&y)
            .map(|(&q, &y)| {
                let e = q as f64 - y;
                loss += e * e / n;
                (2.0 * e / n) as f32
            })
            .collect();
        let mut grad = std::mem::take(&mut self.critic_grad);
        grad.clear();
        grad.resize(self.critic.mlp.n_params(), 0.0);
        self.critic.backprop(&cols, &dq, Some(&mut grad), None);
        self.critic_opt.step(self.critic.mlp.params_mut(), &grad);
        self.critic_grad = grad;
        let tau = self.cfg.polyak as f32;
        for (t, s) in self.target.mlp.params_mut().iter_mut().zip(self.critic.mlp.params()) {
            *t = tau * s + (1.0 - tau) * *t;
        }
        loss
    }

    /// The actor's forward pass over actor step `step`'s minibatch: every valid action of each
    /// transition at its perturbed design, activations kept in the actor for the step's backprop.
    pub(super) fn actor_pass(&mut self, f: &Flat, step: usize) -> ActorPass {
        let d = self.zeta.len();
        let idx = self.minibatch(f.s.len(), (self.cfg.critic_steps + step) as u64);
        let n = idx.iter().map(|&i| self.sets.of(f.s[i]).len()).sum();
        let mut cols = Columns::with_capacity(&self.features, n);
        for &i in &idx {
            for &a in self.sets.of(f.s[i]) {
                cols.push(&self.features, f.s[i], a, &f.zeta[i * d..(i + 1) * d], i as u32);
            }
        }
        let mut logits = Vec::new();
        self.actor.eval(&cols, &mut logits);
        ActorPass { idx, cols, logits }
    }

    /// [`Learner::log_pi_at_pert`] read off an actor pass that covers every transition.
    pub(super) fn log_pi_of_pass(&self, f: &Flat, pass: &ActorPass) -> Vec<f64> {
        let mut out = vec![0.0; f.s.len()];
        let mut probs = Vec::new();
        let mut c = 0;
        for &i in &pass.idx {
            let acts = self.sets.of(f.s[i]);
            out[i] = ln_pi_taken(acts, f.a[i], &pass.logits[c..c + acts.len()], &mut probs);
            c += acts.len();
        }
        out
    }

    /// Cross-entropy fit of π_θ(·|s, ζ_pert) to the critic's Gibbs policy
    /// `∝ π_θ(a|s) exp(−Q_φ(s,a,ζ_pert)/α)` (Q_φ includes the current step's α ln π term, so this
    /// is `∝ exp(−Q̃/α)` with Q̃ the entropy-free action value), on the minibatch of `pass`
    /// (the actor's last forward pass).
    pub(super) fn actor_gibbs_step(&mut self, f: &Flat, pass: ActorPass) -> f64 {
        let ActorPass { idx, cols, logits } = pass;
        let mut q = Vec::new();
        self.critic.values(&cols, &mut q);
        let n = idx.len() as f64;
        let mut dlogit = vec![0.0f32; cols.len()];
        let mut loss = 0.0;
        let (mut pi, mut target, mut z) = (Vec::new(), Vec::new(), Vec::new());
        let mut c = 0;
        for &i in &idx {
            let m = self.sets.of(f.s[i]).len();
            let r = c..c + m;
            pi.resize(m, 0.0);
            softmax(&logits[r.clone()], &mut pi);
            z.clear();
            z.extend(r.clone().map(|j| logits[j] - (q[j] as f64 / self.alpha) as f32));
            target.resize(m, 0.0);
            if z.iter().all(|v| v.is_finite()) {
                softmax(&z, &mut target);
            } else {
                // Q/α is beyond f32's range once the loop back-off has cooled α to ~1e-37 (or
                // to 0): the Gibbs policy is then its α → 0 limit.
                greedy(&q[r.clone()], &mut target);
            }
            for (j, col) in r.clone().enumerate() {
                dlogit[col] = ((pi[j] - target[j]) / n) as f32;
                if target[j] > 0.0 {
                    loss -= target[j] * pi[j].max(f64::MIN_POSITIVE).ln() / n;
                }
            }
            c += m;
        }
        self.actor_apply(&cols, &dlogit);
        loss
    }

    /// The paper's entropy-regularised policy gradient on the on-policy episodes at ζ_k:
    /// `∇θ J_H ≈ (1/M) Σ_episodes Σ_t γ^t (Q_φ(s_t,a_t,ζ_k) + α) ∇θ ln π_θ(a_t|s_t,ζ_k)`.
    pub(super) fn actor_pg_step(&mut self, on: &[&Episode]) -> f64 {
        let zeta = self.zeta.clone();
        let (cols, taken) = self.on_policy_columns(on, &zeta);
        let (mut logits, mut q) = (Vec::new(), Vec::new());
        self.actor.eval(&cols, &mut logits);
        self.critic.values(&cols, &mut q);
        let m_eps = on.len() as f64;
        let mut dlogit = vec![0.0f32; cols.len()];
        let mut surrogate = 0.0;
        let mut pi = Vec::new();
        for &(r_start, m, k_taken, disc) in &taken {
            pi.resize(m, 0.0);
            softmax(&logits[r_start..r_start + m], &mut pi);
            let w = disc * (q[r_start + k_taken] as f64 + self.alpha);
            surrogate += w * pi[k_taken].max(f64::MIN_POSITIVE).ln() / m_eps;
            for j in 0..m {
                let ind = if j == k_taken { 1.0 } else { 0.0 };
                dlogit[r_start + j] = (w * (ind - pi[j]) / m_eps) as f32;
            }
        }
        self.actor_apply(&cols, &dlogit);
        surrogate
    }

    /// Backpropagates `dlogit` through the actor's last evaluation and takes an Adam step.
    pub(super) fn actor_apply(&mut self, cols: &Columns, dlogit: &[f32]) {
        let mut grad = std::mem::take(&mut self.actor_grad);
        grad.clear();
        grad.resize(self.actor.mlp.n_params(), 0.0);
        self.actor.backprop(cols, dlogit, Some(&mut grad), None);
        self.actor_opt.step(self.actor.mlp.params_mut(), &grad);
        self.actor_grad = grad;
    }
}

/// `ln π(a|s)` from the logits of the valid actions `acts` of s (`probs` is scratch).
fn ln_pi_taken(acts: &[usize], a: usize, logits: &[f32], probs: &mut Vec<f64>) -> f64 {
    probs.resize(acts.len(), 0.0);
    softmax(logits, probs);
    let k = acts.iter().position(|&x| x == a).expect("validated");
    probs[k].max(f64::MIN_POSITIVE).ln()
}

/// The α → 0 limit of the Gibbs policy `exp(−Q/α)`: uniform over the actions of least Q.
fn greedy(q: &[f32], out: &mut [f64]) {
    let least = q.iter().fold(f32::INFINITY, |m, &v| m.min(v));
    let ties = q.iter().filter(|&&v| v == least).count() as f64;
    for (o, &v) in out.iter_mut().zip(q) {
        *o = if v == least { 1.0 / ties } else { 0.0 };
    }
}
