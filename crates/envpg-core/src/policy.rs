//! Policies in result files: one row per non-terminal state (in state order), one column per
//! global action, zeros on invalid actions — and conversions to and from the per-pair layout
//! the algorithms use (state by state, each state's valid actions in order).

use crate::mdp::ParamMdp;

/// Why policy rows do not fit an environment.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("policy {0}")]
pub struct PolicyError(pub String);

/// The non-terminal states of `env`, in order: the states result-file rows describe.
pub fn row_states<E: ParamMdp + ?Sized>(env: &E) -> Vec<usize> {
    (0..env.n_states()).filter(|&s| !env.is_terminal(s)).collect()
}

/// Result-file rows of a per-pair policy.
pub fn policy_rows<E: ParamMdp + ?Sized>(env: &E, pairs: &[f64]) -> Vec<Vec<f64>> {
    let mut out = Vec::new();
    let mut first = 0;
    for s in 0..env.n_states() {
        let acts = env.valid_actions(s);
        if !env.is_terminal(s) {
            let mut row = vec![0.0; env.n_actions()];
            for (i, &a) in acts.iter().enumerate() {
                row[a] = pairs[first + i];
            }
            out.push(row);
        }
        first += acts.len();
    }
    out
}

/// The per-pair policy of result-file `rows`, validated: right shape, finite non-negative
/// entries summing to 1 (±1e-9), no mass on invalid actions.
pub fn pairs_from_rows<E: ParamMdp + ?Sized>(env: &E, rows: &[Vec<f64>]) -> Result<Vec<f64>, PolicyError> {
    let states = row_states(env);
    if rows.len() != states.len() {
        return Err(PolicyError(format!(
            "has {} rows, the environment has {} non-terminal states",
            rows.len(),
            states.len()
        )));
    }
    let mut pairs = Vec::new();
    let mut row = rows.iter();
    for s in 0..env.n_states() {
        if env.is_terminal(s) {
            continue;
        }
        let r = row.next().expect("one row per non-terminal state");
        if r.len() != env.n_actions() {
            return Err(PolicyError(format!("row of state {s} has {} entries, expected {}", r.len(), env.n_actions())));
        }
        if let Some(p) = r.iter().find(|p| !(p.is_finite() && **p >= 0.0)) {
            return Err(PolicyError(format!("row of state {s} has an invalid probability {p}")));
        }
        let valid = env.valid_actions(s);
        if let Some((a, p)) = r.iter().enumerate().find(|(a, p)| **p != 0.0 && !valid.contains(a)) {
            return Err(PolicyError(format!("row of state {s} puts mass {p} on invalid action {a}")));
        }
        let sum: f64 = r.iter().sum();
        if (sum - 1.0).abs() > 1e-9 {
            return Err(PolicyError(format!("row of state {s} sums to {sum}, not 1")));
        }
        pairs.extend(valid.iter().map(|&a| r[a]));
    }
    Ok(pairs)
}

/// The greedy action of every state from result-file rows (the most probable valid action,
/// lowest index on ties; 0 for terminal states, which never act).
pub fn actions_from_rows<E: ParamMdp + ?Sized>(env: &E, rows: &[Vec<f64>]) -> Vec<usize> {
    let mut out = vec![0; env.n_states()];
    for (s, r) in row_states(env).into_iter().zip(rows) {
        let mut best: Option<usize> = None;
        for &a in env.valid_actions(s) {
            let p = r.get(a).copied().unwrap_or(0.0);
            if best.is_none_or(|b| p > r.get(b).copied().unwrap_or(0.0)) {
                best = Some(a);
            }
        }
        out[s] = best.unwrap_or(0);
    }
    out
}
