//! Rounds of sampled policy iteration on the polish's deterministic policy: what the polish
//! improves besides the design. Model-free: one-step samples and rollouts through the sampler,
//! from any non-terminal state (so the sampler must be able to start anywhere, as exploring
//! starts are).

use envpg_core::{ParamMdp, Purpose, Streams};

use super::{PolishSettings, on_two_threads};

/// Stream keys of the rounds' one-step samples and rollouts, above any polish iteration.
const POLICY_ONE_STEP: u64 = 1 << 40;
const POLICY_ROLLOUT: u64 = 2 << 40;

/// What one round of policy improvement proposes.
#[derive(Debug, Clone, PartialEq)]
pub struct PolicyProposal {
    /// The lowest-Q action of every state (the old action where nothing is better).
    pub action: Vec<usize>,
    /// States whose action changed.
    pub changed: usize,
    /// Environment steps taken.
    pub transitions: u64,
}

/// One round of sampled policy iteration on the deterministic policy `action` at design `zeta`:
/// V^π of the successors by `policy_samples` rollouts each (discounted by γ), Q of every valid
/// action of every non-terminal state from `policy_samples` one-step samples (the same stream
/// for each action of a state), and the lowest-Q action per state. Same inputs, same proposal.
pub fn improve_policy<E: ParamMdp + Sync + ?Sized>(
    env: &E,
    action: &[usize],
    zeta: &[f64],
    s: &PolishSettings,
    streams: &Streams,
    round: u64,
) -> PolicyProposal {
    let n = env.n_states();
    let gamma = env.gamma();
    let r = s.policy_samples.max(1);
    let states: Vec<usize> = (0..n).filter(|&st| !env.is_terminal(st)).collect();
    // One-step samples: per state and valid action, the cost sum and successor counts.
    let samples = on_two_threads(&states, |&st| {
        let mut steps = 0u64;
        let per_action: Vec<OneStep> = env
            .valid_actions(st)
            .iter()
            .map(|&a| {
                let mut rng = streams.stream(Purpose::Polish, POLICY_ONE_STEP + round, st as u64);
                let mut one = OneStep::default();
                for _ in 0..r {
                    let (s2, c) = env.step(st, a, zeta, &mut rng);
                    one.cost += c;
                    one.sq += c * c;
                    match one.next.iter_mut().find(|x| x.0 == s2) {
                        Some(x) => {
                            x.1 += 1;
                            x.2 += c;
                        }
                        None => one.next.push((s2, 1, c)),
                    }
                }
                steps += r as u64;
                one
            })
            .collect();
        (per_action, steps)
    });
    let mut transitions: u64 = samples.iter().map(|x| x.1).sum();
    // V^π of every non-terminal successor, by rollouts under the current policy.
    let mut needed = vec![false; n];
    for (per_action, _) in &samples {
        for one in per_action {
            for &(s2, _, _) in &one.next {
                needed[s2] = !env.is_terminal(s2);
            }
        }
    }
    let succ: Vec<usize> = (0..n).filter(|&st| needed[st]).collect();
    let values = on_two_threads(&succ, |&st| {
        let mut rng = streams.stream(Purpose::Polish, POLICY_ROLLOUT + round, st as u64);
        let (mut total, mut steps) = (0.0, 0u64);
        for _ in 0..r {
            let mut cur = st;
            let mut disc = 1.0;
            for _ in 0..s.episode_cap {
                let (s2, c) = env.step(cur, action[cur], zeta, &mut rng);
                total += disc * c;
                disc *= gamma;
                steps += 1;
                if env.is_terminal(s2) {
                    break;
                }
                cur = s2;
            }
        }
        (total / r as f64, steps)
    });
    let mut v = vec![0.0; n];
    for (&st, &(val, steps)) in succ.iter().zip(&values) {
        v[st] = val;
        transitions += steps;
    }
    let mut new_action = action.to_vec();
    let mut changed = 0;
    for (&st, (per_action, _)) in states.iter().zip(&samples) {
        let q: Vec<(f64, f64)> = per_action.iter().map(|one| one.q(gamma, &v, r)).collect();
        let acts = env.valid_actions(st);
        let current = acts.iter().position(|&a| a == action[st]);
        let best = (0..q.len()).min_by(|&i, &j| q[i].0.total_cmp(&q[j].0)).expect("a non-terminal state has actions");
        // Switch to the lowest sampled Q, by at least `z` standard errors when asked to.
        let better = |c: usize| q[best].0 < q[c].0 - s.z * (q[best].1.powi(2) + q[c].1.powi(2)).sqrt();
        if current.is_none_or(better) {
            new_action[st] = acts[best];
            changed += 1;
        }
    }
    PolicyProposal { action: new_action, changed, transitions }
}

/// The one-step samples of one (state, action): the sum of their costs and of their squares,
/// and per successor the count and cost sum.
#[derive(Debug, Default)]
struct OneStep {
    cost: f64,
    sq: f64,
    next: Vec<(usize, u32, f64)>,
}

impl OneStep {
    /// The sampled Q = mean of c + γV(s') over the `r` samples, and its standard error (with
    /// V held fixed).
    fn q(&self, gamma: f64, v: &[f64], r: usize) -> (f64, f64) {
        let rf = r as f64;
        let q = (self.cost + gamma * self.next.iter().map(|&(s2, k, _)| k as f64 * v[s2]).sum::<f64>()) / rf;
        // Σ (c + γV)² = Σ c² + 2γ Σ_s' V(s') Σ_{→s'} c + γ² Σ_s' n_s' V(s')².
        let sq = self.sq
            + self
                .next
                .iter()
                .map(|&(s2, k, c)| 2.0 * gamma * v[s2] * c + gamma * gamma * k as f64 * v[s2] * v[s2])
                .sum::<f64>();
        let var = if r > 1 { ((sq - rf * q * q) / (rf - 1.0)).max(0.0) } else { 0.0 };
        (q, (var / rf).sqrt())
    }
}
