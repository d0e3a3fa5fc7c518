//! UAV-specific glue: policy tables as result-file rows, random initial designs, greedy
//! evaluation of a design.

use envpg_core::{ParamMdp, UavNetwork};
use rand::Rng;
use rand_distr::{Distribution, Uniform};

use crate::error::ModelError;
use crate::evaluate::evaluate;
use crate::snapshot::Snapshot;
use crate::soft::{greedy, solve_soft};

/// Result-file rows (users, then UAVs; M+1 global actions) of a per-pair policy.
pub fn policy_rows(net: &UavNetwork, snap: &Snapshot, pi: &[f64]) -> Vec<Vec<f64>> {
    let rows = net.n_users() + net.n_uav();
    (0..rows)
        .map(|s| {
            let mut row = vec![0.0; net.n_actions()];
            for sa in snap.sas(s) {
                row[snap.sa_action[sa]] = pi[sa];
            }
            row
        })
        .collect()
}

/// The per-pair policy of result-file `rows`, validated: right shape, finite non-negative
/// entries summing to 1 (±1e-9), zero mass on invalid actions.
pub fn pairs_from_rows(net: &UavNetwork, snap: &Snapshot, rows: &[Vec<f64>]) -> Result<Vec<f64>, ModelError> {
    let n_rows = net.n_users() + net.n_uav();
    if rows.len() != n_rows {
        return Err(ModelError::Invalid(format!("policy has {} rows, expected {n_rows}", rows.len())));
    }
    let mut pi = vec![0.0; snap.n_pairs()];
    for (s, row) in rows.iter().enumerate() {
        if row.len() != net.n_actions() {
            return Err(ModelError::Invalid(format!(
                "policy row {s} has {} entries, expected {}",
                row.len(),
                net.n_actions()
            )));
        }
        if let Some(p) = row.iter().find(|p| !(p.is_finite() && **p >= 0.0)) {
            return Err(ModelError::Invalid(format!("policy row {s} has an invalid probability {p}")));
        }
        let valid = net.valid_actions(s);
        for (a, &p) in row.iter().enumerate() {
            if p != 0.0 && !valid.contains(&a) {
                return Err(ModelError::Invalid(format!("policy row {s} puts mass {p} on invalid action {a}")));
            }
        }
        let sum: f64 = row.iter().sum();
        if (sum - 1.0).abs() > 1e-9 {
            return Err(ModelError::Invalid(format!("policy row {s} sums to {sum}, not 1")));
        }
        for sa in snap.sas(s) {
            pi[sa] = row[snap.sa_action[sa]];
        }
    }
    Ok(pi)
}

/// A design drawn uniformly over the users' bounding box.
pub fn random_zeta<R: Rng + ?Sized>(net: &UavNetwork, rng: &mut R) -> Vec<f64> {
    let (lo, hi) = net.instance().user_bbox();
    let ux = Uniform::new_inclusive(lo[0], hi[0]).expect("finite box");
    let uy = Uniform::new_inclusive(lo[1], hi[1]).expect("finite box");
    (0..net.n_uav()).flat_map(|_| [ux.sample(rng), uy.sample(rng)]).collect()
}

/// The hard-optimal policy at `zeta` and its exact J.
pub fn optimal_greedy(net: &UavNetwork, zeta: &[f64]) -> Result<(Snapshot, Vec<f64>, f64), ModelError> {
    let snap = Snapshot::build(net, zeta);
    let sol = solve_soft(&snap, 0.0, None)?;
    let j = evaluate(&snap, &sol.pi, 0.0)?.j;
    Ok((snap, sol.pi, j))
}

/// Exact J of the greedy (most probable action) version of `pi` at `snap`.
pub fn greedy_j(snap: &Snapshot, pi: &[f64]) -> Result<(Vec<f64>, f64), ModelError> {
    let g = greedy(snap, pi);
    let j = evaluate(snap, &g, 0.0)?.j;
    Ok((g, j))
}
