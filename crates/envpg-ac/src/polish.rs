//! The ζ polish: a short model-free refinement of the design after the last iteration of
//! Algorithm 1, with the policy held fixed.
//!
//! Why: Algorithm 1 steps the emulator at ζ_k + N(0, σ²I), so it optimises a design for a
//! kernel smoothed over σ. Where the kernel switches over much shorter distances (off-target
//! moves with η = 100 pick the nearest other target, and the nearest one changes within a few
//! thousandths), the smoothed optimum sits a fraction of σ away from the unsmoothed one.
//!
//! How: the greedy policy of the final actor is frozen, and ζ descends the sampled cost
//! `Ĵ(ζ) = (1/E) Σ_e cost of episode e` by central differences with *common random numbers*:
//! episode e draws its start and every transition from the same stream at ζ + h·e_i and
//! ζ − h·e_i, so the difference sees only what ζ changes (costs, and the few draws that switch
//! target). Each step is normalised, and accepted only if the same episodes cost less at the
//! new design; the step grows after an acceptance and shrinks after a refusal. Every iteration
//! draws new episodes (stream `Purpose::Polish`, keyed by iteration and episode).
//!
//! Model-free: the environment is touched only through [`ParamMdp::sample_initial`],
//! [`ParamMdp::step`] and [`ParamMdp::is_terminal`]. It does need an emulator whose randomness
//! the caller supplies (it replays a stream at two designs); Algorithm 1 itself does not.

use envpg_core::{ParamMdp, Purpose, Streams};
use serde::{Deserialize, Serialize};

/// Settings of the polish (copied from [`crate::AcConfig`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PolishSettings {
    /// Iterations (0: no polish).
    pub iterations: usize,
    /// Episodes per cost estimate.
    pub episodes: usize,
    /// Half-width h of the central differences.
    pub h: f64,
    /// First step length (the step is normalised: ζ moves by exactly this much).
    pub step: f64,
    /// Episode length cap.
    pub episode_cap: usize,
}

/// What the polish did, recorded in the result file's `details.polish`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PolishReport {
    /// ζ before the polish (the design Algorithm 1 ended with).
    pub zeta_before: Vec<f64>,
    /// Iterations run.
    pub iterations: usize,
    /// Steps accepted.
    pub accepted: usize,
    /// Sampled cost of the first iteration's episodes at the start design.
    pub j_estimate_before: f64,
    /// Sampled cost of the last iteration's episodes at the final design.
    pub j_estimate_after: f64,
    /// Environment steps taken.
    pub transitions: u64,
}

/// Mean cost of episodes `0..n` of polish iteration `it` at `zeta` under the deterministic
/// policy `action` (one action per state), and the number of steps taken.
fn sampled_cost<E: ParamMdp + Sync>(
    env: &E,
    action: &[usize],
    zeta: &[f64],
    s: &PolishSettings,
    streams: &Streams,
    it: u64,
) -> (f64, u64) {
    let mut total = 0.0;
    let mut steps = 0;
    for e in 0..s.episodes as u64 {
        let mut rng = streams.stream(Purpose::Polish, it, e);
        let mut st = env.sample_initial(&mut rng);
        for _ in 0..s.episode_cap {
            let (s2, c) = env.step(st, action[st], zeta, &mut rng);
            total += c;
            steps += 1;
            if env.is_terminal(s2) {
                break;
            }
            st = s2;
        }
    }
    (total / s.episodes as f64, steps)
}

/// Sampled costs at each design, on two threads when there are designs enough; the values do
/// not depend on the thread count (each is computed whole by one thread).
fn sampled_costs<E: ParamMdp + Sync>(
    env: &E,
    action: &[usize],
    designs: &[Vec<f64>],
    s: &PolishSettings,
    streams: &Streams,
    it: u64,
) -> (Vec<f64>, u64) {
    let half = designs.len().div_ceil(2);
    let run = |ds: &[Vec<f64>]| ds.iter().map(|z| sampled_cost(env, action, z, s, streams, it)).collect::<Vec<_>>();
    let out: Vec<(f64, u64)> = if designs.len() >= 2 {
        std::thread::scope(|scope| {
            let (a, b) = designs.split_at(half);
            let other = scope.spawn(|| run(b));
            let mut first = run(a);
            first.extend(other.join().expect("polish thread"));
            first
        })
    } else {
        run(designs)
    };
    (out.iter().map(|o| o.0).collect(), out.iter().map(|o| o.1).sum())
}

/// Polishes `zeta` for the fixed policy `action` (one action per state; terminal states'
/// entries are unused). Same inputs, same result.
pub fn polish<E: ParamMdp + Sync>(
    env: &E,
    action: &[usize],
    zeta: &[f64],
    s: &PolishSettings,
    streams: &Streams,
) -> (Vec<f64>, PolishReport) {
    let d = zeta.len();
    let mut z = zeta.to_vec();
    let mut report = PolishReport {
        zeta_before: zeta.to_vec(),
        iterations: s.iterations,
        accepted: 0,
        j_estimate_before: f64::NAN,
        j_estimate_after: f64::NAN,
        transitions: 0,
    };
    let mut step = s.step;
    for it in 0..s.iterations as u64 {
        // The design and its 2d neighbours, all on this iteration's episodes.
        let mut designs = vec![z.clone()];
        for i in 0..d {
            for sign in [1.0, -1.0] {
                let mut y = z.clone();
                y[i] += sign * s.h;
                designs.push(y);
            }
        }
        let (j, n) = sampled_costs(env, action, &designs, s, streams, it);
        report.transitions += n;
        if it == 0 {
            report.j_estimate_before = j[0];
        }
        report.j_estimate_after = j[0];
        let g: Vec<f64> = (0..d).map(|i| (j[1 + 2 * i] - j[2 + 2 * i]) / (2.0 * s.h)).collect();
        let norm = g.iter().map(|x| x * x).sum::<f64>().sqrt();
        if !(norm > 0.0 && norm.is_finite()) {
            continue;
        }
        // Backtracking along −g/‖g‖ on the same episodes: a few halvings, then give up this
        // iteration and try a longer step with the next iteration's episodes.
        let mut accepted = false;
        for _ in 0..6 {
            let y: Vec<f64> = z.iter().zip(&g).map(|(zi, gi)| zi - step * gi / norm).collect();
            let (jy, n) = sampled_costs(env, action, std::slice::from_ref(&y), s, streams, it);
            report.transitions += n;
            if jy[0] < j[0] {
                z = y;
                report.j_estimate_after = jy[0];
                report.accepted += 1;
                step *= 1.5;
                accepted = true;
                break;
            }
            step *= 0.5;
        }
        if !accepted {
            step = step.max(s.h / 2.0) * 8.0;
        }
    }
    (z, report)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nets::ActionSets;
    use envpg_core::UavNetwork;
    use envpg_model::{Snapshot, evaluate};

    /// A 20-user, 3-UAV instance at κ = 0.85.
    fn tiny() -> UavNetwork {
        let inst = envpg_core::instance::generate(&envpg_core::instance::GenerateSpec {
            name: "tiny".into(),
            n_users: 20,
            n_uav: 3,
            clusters: 3,
            side: 10.0,
            spread: 0.8,
            seed: 7,
        })
        .unwrap();
        UavNetwork::new(inst, 0.85, 100.0).unwrap()
    }

    fn exact_j(net: &UavNetwork, action: &[usize], zeta: &[f64]) -> f64 {
        let sets = ActionSets::new(net);
        let mut pi = vec![0.0; sets.n_pairs()];
        for s in 0..sets.n_states() {
            if let Some(i) = sets.of(s).iter().position(|&a| a == action[s]) {
                pi[sets.first(s) + i] = 1.0;
            }
        }
        evaluate(&Snapshot::build(net, zeta), &pi, 0.0).unwrap().j
    }

    /// Every user and UAV sends to the destination's nearest UAV chain: here simply "UAV 0"
    /// from users and "destination" from UAVs — a proper policy for any design.
    fn policy(net: &UavNetwork) -> Vec<usize> {
        (0..net.n_states()).map(|s| if s < net.n_users() { 0 } else { net.n_uav() }).collect()
    }

    fn settings(iterations: usize) -> PolishSettings {
        PolishSettings { iterations, episodes: 512, h: 0.005, step: 0.05, episode_cap: 25 }
    }

    #[test]
    fn polish_lowers_the_exact_cost_of_a_fixed_policy_and_is_reproducible() {
        let net = tiny();
        let action = policy(&net);
        // UAV 0 relays every user: start it far from the users' centre.
        let mut zeta: Vec<f64> = net.instance().users[..3].iter().flat_map(|u| [u[0] + 2.0, u[1] - 2.0]).collect();
        zeta[0] += 1.0;
        let before = exact_j(&net, &action, &zeta);
        let streams = Streams::new(3);
        let (z1, r1) = polish(&net, &action, &zeta, &settings(40), &streams);
        let (z2, r2) = polish(&net, &action, &zeta, &settings(40), &streams);
        assert_eq!((&z1, &r1), (&z2, &r2), "same inputs, same result");
        let after = exact_j(&net, &action, &z1);
        assert!(after < 0.9 * before, "exact J {before} → {after}");
        assert!(r1.accepted > 0 && r1.transitions > 0);
        assert_eq!(r1.zeta_before, zeta);
    }

    #[test]
    fn no_iterations_leave_the_design_alone() {
        let net = tiny();
        let zeta = vec![1.0; 6];
        let (z, r) = polish(&net, &policy(&net), &zeta, &settings(0), &Streams::new(1));
        assert_eq!(z, zeta);
        assert_eq!((r.iterations, r.accepted, r.transitions), (0, 0, 0));
    }
}
