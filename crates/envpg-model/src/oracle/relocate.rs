//! Relocation kicks: designs one *design element* (a relay, a facility) away from the best one.
//!
//! On large UAV instances two basins often differ by where a single UAV sits, kilometres apart,
//! with every other UAV nearly in place: too far for a Gaussian kick, and the independent
//! restarts seldom land in the better one. A relocation moves one element to serve a costly hop
//! of the greedy policy at the best design ([`envpg_core::ParamMdp::relocate`]), in the spirit
//! of the swap moves of local search for facility location.
//!
//! [`relocations`] draws [`TARGETS`] initial states, each with probability proportional to its
//! share of J (a badly served user is likelier), and moves each element to serve each drawn
//! state's first hop — but not an element that already serves it, whose move would be a small
//! step inside the same basin. The candidates are scored by the exact J of their greedy policy
//! before any re-optimisation, and the best ones, each moving a different element, start the
//! round's relocation kicks.

use std::sync::atomic::{AtomicUsize, Ordering};

use envpg_core::ModelMdp;
use rand::RngExt;

use crate::error::ModelError;
use crate::evaluate::{evaluate, mu_dense, optimal_greedy};

/// Initial states a round draws (with replacement) as targets.
pub const TARGETS: usize = 16;

/// Up to `n` designs, each `zeta` with one design element moved to serve the first hop of a
/// drawn initial state: the `n` best candidates by exact greedy J, each moving a different
/// element. The draws come from `rng`; the candidates are scored on up to `threads` threads,
/// with the same result for any thread count. Empty if the environment has fewer than two
/// design elements or relocates none.
pub(super) fn relocations<M: ModelMdp + ?Sized>(
    model: &M,
    zeta: &[f64],
    n: usize,
    rng: &mut envpg_core::EnvRng,
    threads: usize,
) -> Result<Vec<Vec<f64>>, ModelError> {
    let elements = model.design_elements();
    if elements.len() < 2 || n == 0 {
        return Ok(Vec::new());
    }
    let (snap, pi, _) = optimal_greedy(model, zeta)?;
    let v = evaluate(&snap, &pi, 0.0)?.v;
    let share: Vec<f64> = mu_dense(&snap).iter().zip(&v).map(|(m, v)| m * v.max(0.0)).collect();
    let total: f64 = share.iter().sum();
    if total.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) || !total.is_finite() {
        return Ok(Vec::new());
    }
    // The hop a state takes under the greedy policy (to its most probable successor).
    let hop = |s: usize| -> Option<usize> {
        let sa = snap.sas(s).max_by(|&a, &b| pi[a].total_cmp(&pi[b]).then(b.cmp(&a)))?;
        let o = snap.outs(sa).max_by(|&a, &b| snap.prob[a].total_cmp(&snap.prob[b]).then(b.cmp(&a)))?;
        Some(snap.next[o])
    };
    let mut targets: Vec<(usize, usize)> = Vec::new();
    for _ in 0..TARGETS {
        let mut u = rng.random::<f64>() * total;
        let s = share.iter().position(|&w| {
            u -= w;
            u < 0.0
        });
        let s = s.unwrap_or_else(|| share.iter().rposition(|&w| w > 0.0).expect("a positive share"));
        if let Some(t) = hop(s)
            && !targets.iter().any(|&(s0, _)| s0 == s)
        {
            targets.push((s, t));
        }
    }
    let space = model.zeta_space();
    let mut designs: Vec<(usize, Vec<f64>)> = Vec::new();
    for (e, el) in elements.iter().enumerate() {
        for &(s, t) in &targets {
            if el.states.contains(&s) || el.states.contains(&t) {
                continue;
            }
            if let Some(coords) = model.relocate(el, zeta, s, t) {
                let mut z = zeta.to_vec();
                z[el.coords.clone()].copy_from_slice(&coords);
                space.project(&mut z);
                designs.push((e, z));
            }
        }
    }
    let scores = score(model, &designs, threads)?;
    let mut order: Vec<usize> = (0..designs.len()).collect();
    order.sort_by(|&a, &b| scores[a].total_cmp(&scores[b]).then(a.cmp(&b)));
    let mut moved = Vec::new();
    let mut out = Vec::new();
    for i in order {
        let (e, z) = &designs[i];
        if out.len() < n && !moved.contains(e) {
            moved.push(*e);
            out.push(z.clone());
        }
    }
    Ok(out)
}

/// The exact greedy J of each design, on up to `threads` threads (each takes the next design
/// not yet scored; the scores do not depend on which thread made them).
fn score<M: ModelMdp + ?Sized>(
    model: &M,
    designs: &[(usize, Vec<f64>)],
    threads: usize,
) -> Result<Vec<f64>, ModelError> {
    let next = AtomicUsize::new(0);
    let scores: Vec<std::sync::OnceLock<Result<f64, ModelError>>> =
        (0..designs.len()).map(|_| std::sync::OnceLock::new()).collect();
    std::thread::scope(|scope| {
        for _ in 0..threads.clamp(1, designs.len().max(1)) {
            scope.spawn(|| {
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    if i >= designs.len() {
                        break;
                    }
                    let _ = scores[i].set(optimal_greedy(model, &designs[i].1).map(|(_, _, j)| j));
                }
            });
        }
    });
    scores.into_iter().map(|s| s.into_inner().expect("every design scored")).collect()
}

#[cfg(test)]
mod tests {
    use envpg_core::{Purpose, Streams};

    use super::*;

    /// The screen's designs come best first by exact greedy J, each moves one element a
    /// different one from the others, and they do not depend on the thread count.
    #[test]
    fn relocations_come_best_first_each_moving_another_element_whatever_the_threads() {
        let env = envpg_envs::registry().load("uav271", &[]).unwrap();
        let model = env.model().unwrap();
        let zeta = model.clustered_design(&mut Streams::new(3).stream(Purpose::Zeta0, 0, 0)).unwrap();
        let draw = |threads| {
            let mut rng = Streams::new(7).stream(Purpose::Oracle, 0, 1);
            relocations(model, &zeta, 3, &mut rng, threads).unwrap()
        };
        let one = draw(1);
        assert_eq!(one, draw(2));
        assert_eq!(one.len(), 3);
        let elements = model.design_elements();
        let moved: Vec<usize> = one
            .iter()
            .map(|z| {
                let changed: Vec<usize> =
                    (0..elements.len()).filter(|&e| elements[e].coords.clone().any(|i| z[i] != zeta[i])).collect();
                assert_eq!(changed.len(), 1);
                changed[0]
            })
            .collect();
        assert!(moved[0] != moved[1] && moved[1] != moved[2] && moved[0] != moved[2]);
        let j: Vec<f64> = one.iter().map(|z| optimal_greedy(model, z).unwrap().2).collect();
        assert!(j[0] <= j[1] && j[1] <= j[2], "{j:?}");
    }
}
