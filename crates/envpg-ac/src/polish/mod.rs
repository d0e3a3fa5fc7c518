//! The ζ polish: a short model-free refinement of the design after the last iteration of
//! Algorithm 1, for the actor's greedy policy (held fixed, or improved by sampled policy
//! iteration along the way), from one or several starts.
//!
//! Why: Algorithm 1 steps the emulator at ζ_k + N(0, σ²I), so it optimises a design for a
//! kernel smoothed over σ. Where the kernel switches over much shorter distances (in the UAV
//! network, off-target moves with η = 100 pick the nearest other target, and the nearest one
//! changes within a few thousandths), the smoothed optimum sits a fraction of σ away from the
//! unsmoothed one.
//!
//! How: with the policy (deterministic) held fixed, ζ descends the sampled cost
//! `Ĵ(ζ) = (1/E) Σ_e cost of episode e` by central differences with *common random numbers*:
//! episode e draws its start and every transition from the same stream at ζ + h·e_i and
//! ζ − h·e_i, so the difference sees only what ζ changes (costs, and the few draws that switch
//! target). Each step is normalised, and accepted only if the same episodes cost less at the
//! new design; the step grows after an acceptance and shrinks after a refusal. Every iteration
//! draws new episodes (stream `Purpose::Polish`, keyed by iteration and episode). Designs stay
//! inside the design bounds: steps and starts are projected, and a difference at a bound is
//! one-sided. With γ < 1 an episode's cost is discounted.
//!
//! The policy can be improved along the way ([`PolishSettings::policy_rounds`], `polish/improve.rs`): a
//! round of sampled policy iteration at the current design estimates V^π of every state the
//! policy can move to by rollouts, then Q(s, a) = E[c + γV^π(s')] of every valid action of every
//! state from one-step samples (common random numbers across the actions of a state), and
//! switches each state to its lowest-Q action. The new policy is kept only if the polish's
//! episodes cost less under it. Everywhere the polish compares sampled costs of an SSP, a sample
//! with more than 1 in 1000 episodes at the length cap counts as looping and loses to any that
//! does not (`polish/sampled.rs`). Without the rounds the polish stops where the old policy stops being
//! the best one for the moved design; with them, design and policy approach a joint local
//! optimum, as the model's local optimiser does.
//!
//! Several starts can be polished ([`polish_candidates`]): the design Algorithm 1 ends with
//! and a few designs scattered around it, each with the actor's greedy policy at that design.
//! Each gets a short screening polish; the one whose sampled cost (on episodes common to all)
//! is lowest is kept and polished to the end. Design and policy together have local optima a
//! few tenths apart, and a start from a neighbouring one is cheap to try.
//!
//! Model-free: the environment is touched only through its sampler
//! ([`ParamMdp::sample_initial`], [`ParamMdp::step`], [`ParamMdp::valid_actions`],
//! [`ParamMdp::is_terminal`]). It does need a sampler whose randomness the caller supplies (it
//! replays a stream at two designs, as every envpg sampler does) and, for the policy rounds,
//! one that can be stepped from any state (as exploring starts are); Algorithm 1 itself needs
//! neither.

mod improve;
mod rank;
mod sampled;

use envpg_core::{ParamMdp, Purpose, Streams, ZetaSpace};
pub use improve::{PolicyProposal, improve_policy};
use rand::RngExt;
use rand_distr::StandardNormal;
pub use rank::{RANKING_EPISODES, RankScore, best_of, rank_designs, score_designs};
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
    /// Rounds of sampled policy iteration on the policy, spread evenly over the iterations
    /// (the first before iteration 0; 0: the policy stays frozen).
    pub policy_rounds: usize,
    /// One-step samples per (state, action), and rollouts per state for V^π, of a round.
    pub policy_samples: usize,
    /// Starting designs of [`polish_candidates`] (1: only the given design).
    pub candidates: usize,
    /// Standard deviation of the other starts' offsets from the given design.
    pub candidate_spread: f64,
    /// Screening iterations per start before the best is kept.
    pub screen_iterations: usize,
    /// Significance, in standard errors, that a ζ step, a new policy and a state's switch to
    /// another action need (paired over common random numbers): 0 accepts any sampled
    /// improvement.
    pub z: f64,
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
    /// Policy rounds run.
    #[serde(default, alias = "routing_rounds")]
    pub policy_rounds: usize,
    /// Policy rounds whose new policy was kept.
    #[serde(default, alias = "routing_accepted")]
    pub policy_accepted: usize,
    /// States whose action changed, summed over the kept rounds.
    #[serde(default, alias = "routing_changes")]
    pub policy_changes: usize,
    /// The screened starting designs (empty with one start).
    #[serde(default)]
    pub candidates: Vec<PolishCandidate>,
    /// Index of the candidate kept and polished to the end.
    #[serde(default)]
    pub kept: usize,
}

/// One screened start of [`polish_candidates`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PolishCandidate {
    /// Its starting design.
    pub start: Vec<f64>,
    /// Its design after the screening polish.
    pub zeta: Vec<f64>,
    /// Sampled cost after screening, on the selection episodes (the same for every candidate).
    pub j_estimate: f64,
    /// Selection episodes that hit the length cap; above 1 in 1000 (in an SSP) the policy
    /// counts as looping and ranks after every policy that does not.
    #[serde(default)]
    pub capped: u64,
}

/// Stream keys of the candidate selection and the candidates' starts, above any polish
/// iteration (the policy rounds use `1 << 40` and `2 << 40`).
const SELECTION: u64 = 3 << 40;
const STARTS: u64 = 4 << 40;

/// The starting designs of [`polish_candidates`]: `zeta` itself, then `candidates − 1`
/// designs `zeta + N(0, candidate_spread²I)`, projected onto `space`. Same inputs, same starts.
pub fn candidate_starts(zeta: &[f64], s: &PolishSettings, streams: &Streams, space: &ZetaSpace) -> Vec<Vec<f64>> {
    (0..s.candidates.max(1) as u64)
        .map(|c| {
            if c == 0 {
                return zeta.to_vec();
            }
            let mut rng = streams.stream(Purpose::Polish, STARTS, c);
            let mut z: Vec<f64> =
                zeta.iter().map(|z| z + s.candidate_spread * rng.sample::<f64, _>(StandardNormal)).collect();
            space.project(&mut z);
            z
        })
        .collect()
}

/// Polishes from several starts `(design, policy)` and keeps the best: each start gets a
/// screening polish of `screen_iterations` (with a proportional share of the policy rounds,
/// at least one, and half the episodes and samples), the screened candidates are ranked by
/// their sampled cost on `4 · episodes` common episodes, and the lowest is polished for
/// `iterations` more. With one start this is [`polish`]. Model-free like [`polish`]; same
/// inputs, same result.
pub fn polish_candidates<E: ParamMdp + Sync + ?Sized>(
    env: &E,
    starts: &[(Vec<f64>, Vec<usize>)],
    s: &PolishSettings,
    streams: &Streams,
) -> (Vec<f64>, Vec<usize>, PolishReport) {
    assert!(!starts.is_empty(), "polish_candidates needs a start");
    if starts.len() == 1 || s.iterations == 0 {
        return polish(env, &starts[0].1, &starts[0].0, s, streams);
    }
    // Screening only has to tell basins apart: half the episodes and samples of the polish.
    let screen = PolishSettings {
        iterations: s.screen_iterations,
        episodes: s.episodes.div_ceil(2),
        policy_samples: s.policy_samples.div_ceil(2),
        policy_rounds: if s.policy_rounds == 0 {
            0
        } else {
            (s.policy_rounds * s.screen_iterations).div_ceil(s.iterations.max(1)).max(1)
        },
        ..*s
    };
    // Every candidate screens on the same episodes (common random numbers across starts).
    let screened: Vec<(Vec<f64>, Vec<usize>, PolishReport)> =
        starts.iter().map(|(z, a)| polish_run(env, a, z, &screen, streams, 0)).collect();
    let selection = PolishSettings { episodes: 4 * s.episodes, ..*s };
    let episodes = sampled::Episodes::new(streams, SELECTION, selection.episodes);
    let scores = on_two_threads(&screened, |(z, a, _)| sampled::sampled_cost(env, a, z, &selection, &episodes));
    let kept = (0..scores.len()).min_by(|&a, &b| scores[a].rank(&scores[b])).expect("starts");
    let (z, a, _) = &screened[kept];
    let (z, a, mut report) = polish_run(env, a, z, s, streams, s.screen_iterations as u64);
    report.zeta_before = starts[0].0.clone();
    report.j_estimate_before = screened[0].2.j_estimate_before;
    for (r, sc) in screened.iter().map(|x| &x.2).zip(&scores) {
        report.transitions += r.transitions + sc.steps;
        report.accepted += r.accepted;
        report.policy_rounds += r.policy_rounds;
        report.policy_accepted += r.policy_accepted;
        report.policy_changes += r.policy_changes;
    }
    report.iterations += starts.len() * s.screen_iterations;
    report.candidates = starts
        .iter()
        .zip(&screened)
        .zip(&scores)
        .map(|(((start, _), (z, _, _)), sc)| PolishCandidate {
            start: start.clone(),
            zeta: z.clone(),
            j_estimate: sc.cost,
            capped: sc.capped,
        })
        .collect();
    report.kept = kept;
    (z, a, report)
}

/// Runs `f` on every item of `items`, on two threads when there are items enough; the result
/// does not depend on the thread count (each item is computed whole by one thread).
pub(crate) fn on_two_threads<T: Sync, U: Send>(items: &[T], f: impl Fn(&T) -> U + Sync) -> Vec<U> {
    if items.len() < 2 {
        return items.iter().map(&f).collect();
    }
    std::thread::scope(|scope| {
        let (a, b) = items.split_at(items.len().div_ceil(2));
        let other = scope.spawn(|| b.iter().map(&f).collect::<Vec<_>>());
        let mut first: Vec<U> = a.iter().map(&f).collect();
        first.extend(other.join().expect("polish thread"));
        first
    })
}

/// Polishes `zeta` for the policy `action` (one action per state; terminal states' entries
/// are unused), improving that policy on the way when `policy_rounds > 0`. Returns the
/// design and the policy it was polished for. Same inputs, same result.
pub fn polish<E: ParamMdp + Sync + ?Sized>(
    env: &E,
    action: &[usize],
    zeta: &[f64],
    s: &PolishSettings,
    streams: &Streams,
) -> (Vec<f64>, Vec<usize>, PolishReport) {
    polish_run(env, action, zeta, s, streams, 0)
}

/// [`polish`] with its iterations (and policy rounds) drawing the episodes of polish
/// iterations `first..`, so that screening and the final polish use different episodes.
fn polish_run<E: ParamMdp + Sync + ?Sized>(
    env: &E,
    action: &[usize],
    zeta: &[f64],
    s: &PolishSettings,
    streams: &Streams,
    first: u64,
) -> (Vec<f64>, Vec<usize>, PolishReport) {
    let d = zeta.len();
    let mut z = zeta.to_vec();
    let mut action = action.to_vec();
    let space = env.zeta_space();
    let rounds = s.policy_rounds.min(s.iterations);
    let round_at = |it: u64| (0..rounds as u64).find(|r| r * s.iterations as u64 / rounds as u64 == it);
    let mut report = PolishReport {
        zeta_before: zeta.to_vec(),
        iterations: s.iterations,
        accepted: 0,
        j_estimate_before: f64::NAN,
        j_estimate_after: f64::NAN,
        transitions: 0,
        policy_rounds: 0,
        policy_accepted: 0,
        policy_changes: 0,
        candidates: Vec::new(),
        kept: 0,
    };
    let mut step = s.step;
    for local in 0..s.iterations as u64 {
        let it = first + local;
        let episodes = sampled::Episodes::new(streams, it, s.episodes);
        if let Some(round) = round_at(local) {
            let p = improve_policy(env, &action, &z, s, streams, first + round);
            report.transitions += p.transitions;
            report.policy_rounds += 1;
            if p.changed > 0 {
                // Kept only if this iteration's episodes cost less under it.
                let j = sampled::sampled_costs_of(env, &[&action, &p.action], &z, s, &episodes);
                report.transitions += j.iter().map(|x| x.steps).sum::<u64>();
                if j[1].improves_on(&j[0], s.z) {
                    action = p.action;
                    report.policy_accepted += 1;
                    report.policy_changes += p.changed;
                }
            }
        }
        let action = &action[..];
        // The design and its 2d neighbours (inside the bounds), all on this iteration's episodes.
        let mut designs = vec![z.clone()];
        let mut width = Vec::with_capacity(d);
        for i in 0..d {
            let (lo, hi) = (space.lower()[i], space.upper()[i]);
            let (up, down) = ((z[i] + s.h).min(hi), (z[i] - s.h).max(lo));
            width.push(if up == z[i] + s.h && down == z[i] - s.h { 2.0 * s.h } else { up - down });
            for y_i in [up, down] {
                let mut y = z.clone();
                y[i] = y_i;
                designs.push(y);
            }
        }
        let j = sampled::sampled_costs(env, action, &designs, s, &episodes);
        report.transitions += j.iter().map(|x| x.steps).sum::<u64>();
        if local == 0 {
            report.j_estimate_before = j[0].cost;
        }
        report.j_estimate_after = j[0].cost;
        let g: Vec<f64> = (0..d)
            .map(|i| if width[i] > 0.0 { (j[1 + 2 * i].cost - j[2 + 2 * i].cost) / width[i] } else { 0.0 })
            .collect();
        let norm = g.iter().map(|x| x * x).sum::<f64>().sqrt();
        if !(norm > 0.0 && norm.is_finite()) {
            continue;
        }
        // Backtracking along −g/‖g‖ on the same episodes: a few halvings, then give up this
        // iteration and try a longer step with the next iteration's episodes.
        let mut accepted = false;
        for _ in 0..6 {
            let mut y: Vec<f64> = z.iter().zip(&g).map(|(zi, gi)| zi - step * gi / norm).collect();
            space.project(&mut y);
            let jy = sampled::sampled_cost(env, action, &y, s, &episodes);
            report.transitions += jy.steps;
            if jy.improves_on(&j[0], s.z) {
                z = y;
                report.j_estimate_after = jy.cost;
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
    (z, action, report)
}

#[cfg(test)]
mod tests {
    use super::sampled::{Episodes, Sampled, sampled_cost};
    use super::*;
    use crate::nets::ActionSets;
    use envpg_envs::uav::{GenerateSpec, UavNetwork, generate};
    use envpg_model::{Snapshot, evaluate};

    /// A 20-user, 3-UAV instance at κ = 0.85.
    pub(super) fn tiny() -> UavNetwork {
        tiny_at(0.85)
    }

    /// The same instance at another κ.
    fn tiny_at(kappa: f64) -> UavNetwork {
        let inst = generate(&GenerateSpec {
            name: "tiny".into(),
            n_users: 20,
            n_uav: 3,
            clusters: 3,
            side: 10.0,
            spread: 0.8,
            seed: 7,
        })
        .unwrap();
        UavNetwork::new(inst, kappa, 100.0).unwrap()
    }

    pub(super) fn exact_j(net: &UavNetwork, action: &[usize], zeta: &[f64]) -> f64 {
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
    pub(super) fn policy(net: &UavNetwork) -> Vec<usize> {
        (0..net.n_states()).map(|s| if s < net.n_users() { 0 } else { net.n_uav() }).collect()
    }

    pub(super) fn settings(iterations: usize) -> PolishSettings {
        PolishSettings {
            iterations,
            episodes: 512,
            h: 0.005,
            step: 0.05,
            episode_cap: 25,
            policy_rounds: 0,
            policy_samples: 0,
            candidates: 1,
            candidate_spread: 0.0,
            screen_iterations: 0,
            z: 0.0,
        }
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
        let (z1, _, r1) = polish(&net, &action, &zeta, &settings(40), &streams);
        let (z2, _, r2) = polish(&net, &action, &zeta, &settings(40), &streams);
        assert_eq!((&z1, &r1), (&z2, &r2), "same inputs, same result");
        let after = exact_j(&net, &action, &z1);
        assert!(after < 0.9 * before, "exact J {before} → {after}");
        assert!(r1.accepted > 0 && r1.transitions > 0);
        assert_eq!(r1.zeta_before, zeta);
    }

    /// The exact policy-improvement step of `action` at `zeta`: per non-terminal state, the
    /// exact Q^π(s, a) = r̄(s, a) + Σ p V^π(s') of every valid action.
    fn exact_q(net: &UavNetwork, action: &[usize], zeta: &[f64]) -> Vec<Vec<(usize, f64)>> {
        let sets = ActionSets::new(net);
        let snap = Snapshot::build(net, zeta);
        let v = evaluate(&snap, &sets.one_hot(action), 0.0).unwrap().v;
        (0..net.n_states())
            .map(|s| snap.sas(s).map(|sa| (snap.sa_action[sa], snap.rbar[sa] + snap.expect(sa, &v))).collect())
            .collect()
    }

    #[test]
    fn a_policy_round_takes_the_exact_improving_action_wherever_it_is_clear() {
        let net = tiny();
        let action = policy(&net);
        let zeta: Vec<f64> = net.instance().users[..3].iter().flat_map(|u| [u[0] + 0.5, u[1] - 0.5]).collect();
        let s = PolishSettings { policy_samples: 4096, ..settings(1) };
        let p = improve_policy(&net, &action, &zeta, &s, &Streams::new(5), 0);
        assert_eq!(p, improve_policy(&net, &action, &zeta, &s, &Streams::new(5), 0), "same inputs, same proposal");
        let q = exact_q(&net, &action, &zeta);
        let mut clear = 0;
        for st in (0..net.n_states()).filter(|&st| !net.is_terminal(st)) {
            let mut qs = q[st].clone();
            qs.sort_by(|a, b| a.1.total_cmp(&b.1));
            // Where the best action beats the runner-up by 5%, sampling must find it.
            if qs.len() == 1 || qs[0].1 < 0.95 * qs[1].1 {
                assert_eq!(p.action[st], qs[0].0, "state {st}: exact Q {qs:?}");
                clear += 1;
            }
        }
        assert!(clear > net.n_users() / 2, "the test must check most states ({clear})");
        assert!(p.changed > 0, "policy() sends every user to UAV 0: some must change");
        assert!(exact_j(&net, &p.action, &zeta) < exact_j(&net, &action, &zeta));
    }

    #[test]
    fn policy_rounds_let_the_polish_go_below_the_frozen_policy() {
        let net = tiny();
        let action = policy(&net);
        let zeta: Vec<f64> = net.instance().users[..3].iter().flat_map(|u| [u[0] + 1.0, u[1] - 1.0]).collect();
        let streams = Streams::new(2);
        let (zf, af, _) = polish(&net, &action, &zeta, &settings(20), &streams);
        assert_eq!(af, action, "without rounds the policy is frozen");
        let s = PolishSettings { policy_rounds: 4, policy_samples: 512, ..settings(20) };
        let (zr, ar, r) = polish(&net, &action, &zeta, &s, &streams);
        assert_eq!((r.policy_rounds, r.policy_accepted > 0), (4, true), "{r:?}");
        let (frozen, improved) = (exact_j(&net, &af, &zf), exact_j(&net, &ar, &zr));
        assert!(improved < 0.95 * frozen, "exact J: frozen policy {frozen}, improved policy {improved}");
    }

    #[test]
    fn the_candidate_with_the_lowest_sampled_cost_is_kept() {
        let net = tiny();
        let action = policy(&net);
        let users = &net.instance().users;
        // Candidate 1 has UAV 0 (every user's relay) amid the users; candidate 0 far away.
        let near: Vec<f64> = users[..3].iter().flat_map(|u| [u[0], u[1]]).collect();
        let far: Vec<f64> = near.iter().map(|x| x + 6.0).collect();
        let s = PolishSettings { candidates: 2, candidate_spread: 0.3, screen_iterations: 2, ..settings(4) };
        let starts = vec![(far.clone(), action.clone()), (near.clone(), action.clone())];
        let streams = Streams::new(9);
        let (z, a, r) = polish_candidates(&net, &starts, &s, &streams);
        assert_eq!(r.kept, 1, "{r:?}");
        assert!(r.candidates[1].j_estimate < r.candidates[0].j_estimate);
        assert_eq!((r.zeta_before.clone(), r.iterations), (far, 4 + 2 * 2));
        assert!(exact_j(&net, &a, &z) < exact_j(&net, &action, &r.candidates[0].zeta));
        let again = polish_candidates(&net, &starts, &s, &streams);
        assert_eq!((z, a, r), again, "same inputs, same result");
        let starts = candidate_starts(&near, &s, &streams, envpg_core::ParamMdp::zeta_space(&net));
        assert_eq!((starts.len(), &starts[0]), (2, &near));
        assert_ne!(starts[1], near);
    }

    #[test]
    fn a_looping_policy_never_wins_on_the_little_it_costs_before_the_cap() {
        // κ = 1: no off-target move ever breaks the loop.
        let net = tiny_at(1.0);
        let proper = policy(&net);
        // UAVs 0 and 1 side by side amid the users, passing packets to each other: each hop
        // between them is nearly free, and every episode runs into the cap.
        let mut looping = proper.clone();
        looping[net.n_users()] = 1;
        looping[net.n_users() + 1] = 0;
        let users = &net.instance().users;
        let n = users.len() as f64;
        let c = users.iter().fold([0.0, 0.0], |a, u| [a[0] + u[0] / n, a[1] + u[1] / n]);
        let zeta = vec![c[0], c[1], c[0] + 0.001, c[1], c[0], c[1] + 3.0];
        let s = settings(2);
        let streams = Streams::new(4);
        let episodes = Episodes::new(&streams, 0, s.episodes);
        let (p, l) =
            (sampled_cost(&net, &proper, &zeta, &s, &episodes), sampled_cost(&net, &looping, &zeta, &s, &episodes));
        assert!(l.capped > 0 && p.capped == 0, "{l:?} {p:?}");
        assert!(l.cost < p.cost, "the trap: capped episodes look cheap ({l:?} {p:?})");
        assert!(l.loops() && !p.loops());
        assert!(p.beats(&l) && !l.beats(&p));
        // A proper policy's rare long episode is not a loop: then the cost decides.
        let rare = Sampled { capped: 1, episodes: 8192, cost: p.cost - 1.0, ..p.clone() };
        assert!(!rare.loops() && rare.beats(&p));
        let s = PolishSettings { candidates: 2, screen_iterations: 1, ..s };
        let (_, a, r) = polish_candidates(&net, &[(zeta.clone(), looping), (zeta, proper.clone())], &s, &streams);
        assert_eq!((r.kept, a), (1, proper), "{r:?}");
    }

    #[test]
    fn no_iterations_leave_the_design_alone() {
        let net = tiny();
        let zeta = vec![1.0; 6];
        let (z, _, r) = polish(&net, &policy(&net), &zeta, &settings(0), &Streams::new(1));
        assert_eq!(z, zeta);
        assert_eq!((r.iterations, r.accepted, r.transitions), (0, 0, 0));
    }
}
