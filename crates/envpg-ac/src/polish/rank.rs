//! Ranking finished designs, model-free: the (design, policy) pairs several passes of
//! Algorithm 1 ended with are sampled on the same episodes (common random numbers), and the
//! lowest sampled cost wins — a sample that loops losing to any that does not, as everywhere in
//! the polish. What `envpg-launch --passes` keeps.

use envpg_core::{ParamMdp, Streams};
use serde::{Deserialize, Serialize};

use super::{PolishSettings, on_two_threads, sampled};

/// Stream key of the ranking's episodes, above the polish's iterations, policy rounds (`1 << 40`,
/// `2 << 40`), candidate selection (`3 << 40`) and starts (`4 << 40`).
const RANKING: u64 = 5 << 40;

/// Episodes of a ranking, as a multiple of the polish's episodes per estimate: a ranking decides
/// once between designs whose costs may differ by a fraction of a percent, where a polish step
/// decides between neighbours many times.
pub const RANKING_EPISODES: usize = 8;

/// One design's sampled cost in a ranking.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RankScore {
    /// Mean episode cost on the ranking's episodes.
    pub j_estimate: f64,
    /// Episodes that hit the length cap.
    pub capped: u64,
    /// Whether the policy loops there (an SSP with more than 1 in 1000 episodes capped).
    pub loops: bool,
    /// Environment steps taken.
    pub transitions: u64,
}

impl RankScore {
    /// The ranking's order, the polish's: a score that loops after any that does not (fewer
    /// capped episodes first among those that loop), then by sampled cost.
    pub fn rank(&self, other: &RankScore) -> std::cmp::Ordering {
        let key = |x: &RankScore| (x.loops, if x.loops { x.capped } else { 0 });
        key(self).cmp(&key(other)).then(self.j_estimate.total_cmp(&other.j_estimate))
    }
}

/// The index of the best of `scores` by [`RankScore::rank`]; ties go to the earlier one.
pub fn best_of(scores: &[RankScore]) -> usize {
    // min_by keeps the first of equal elements.
    (0..scores.len()).min_by(|&a, &b| scores[a].rank(&scores[b])).expect("best_of needs a score")
}

/// Samples each `(design, policy)` of `designs` (one action per state) on
/// `RANKING_EPISODES · s.episodes` common episodes of `streams` and returns its score. A
/// design's score depends on it and `streams` only, not on what else is scored with it or in
/// which order, so scores from several calls rank together ([`best_of`]). Model-free: the
/// environment is only stepped. Same inputs, same result, whatever the thread count.
pub fn score_designs<E: ParamMdp + Sync + ?Sized>(
    env: &E,
    designs: &[(Vec<f64>, Vec<usize>)],
    s: &PolishSettings,
    streams: &Streams,
) -> Vec<RankScore> {
    let settings = PolishSettings { episodes: RANKING_EPISODES * s.episodes.max(1), z: 0.0, ..*s };
    let episodes = sampled::Episodes::new(streams, RANKING, settings.episodes);
    let samples = on_two_threads(designs, |(z, a)| sampled::sampled_cost(env, a, z, &settings, &episodes));
    samples
        .iter()
        .map(|x| RankScore { j_estimate: x.cost, capped: x.capped, loops: x.loops(), transitions: x.steps })
        .collect()
}

/// [`score_designs`], and the index of the best ([`best_of`]).
pub fn rank_designs<E: ParamMdp + Sync + ?Sized>(
    env: &E,
    designs: &[(Vec<f64>, Vec<usize>)],
    s: &PolishSettings,
    streams: &Streams,
) -> (usize, Vec<RankScore>) {
    assert!(!designs.is_empty(), "rank_designs needs a design");
    let scores = score_designs(env, designs, s, streams);
    (best_of(&scores), scores)
}

#[cfg(test)]
mod tests {
    use super::super::tests::{exact_j, policy, tiny};
    use super::*;

    fn settings() -> PolishSettings {
        PolishSettings { episodes: 256, ..super::super::tests::settings(0) }
    }

    /// Two designs whose exact costs differ by more than 10% (UAVs at the users' first three
    /// positions, and the same moved away): the sampled costs rank them as the exact costs do,
    /// whatever order they are listed in, and each estimate is near its exact cost.
    #[test]
    fn the_design_with_the_lower_exact_cost_ranks_first_in_any_order() {
        let net = tiny();
        let action = policy(&net);
        let near: Vec<f64> = net.instance().users[..3].iter().flat_map(|u| [u[0], u[1]]).collect();
        let far: Vec<f64> = near.iter().map(|x| x + 3.0).collect();
        let (j_near, j_far) = (exact_j(&net, &action, &near), exact_j(&net, &action, &far));
        assert!((j_near - j_far).abs() > 0.1 * j_near.min(j_far), "{j_near} vs {j_far}");
        let lower = usize::from(j_near < j_far);
        let streams = Streams::new(3);
        let designs = vec![(far.clone(), action.clone()), (near.clone(), action.clone())];
        let (best, scores) = rank_designs(&net, &designs, &settings(), &streams);
        assert_eq!(best, lower, "{scores:?}, exact {j_far} and {j_near}");
        for (sc, j) in scores.iter().zip([j_far, j_near]) {
            assert!(!sc.loops && sc.transitions >= 8 * 256, "{sc:?}");
            assert!((sc.j_estimate - j).abs() < 0.05 * j, "estimate {} vs exact {j}", sc.j_estimate);
        }
        let (best2, scores2) = rank_designs(&net, &[designs[1].clone(), designs[0].clone()], &settings(), &streams);
        assert_eq!(best2, 1 - lower);
        assert_eq!((&scores2[0], &scores2[1]), (&scores[1], &scores[0]), "the same episodes whatever the order");
        // Scored alone, each design scores as it did beside the other.
        for (i, d) in designs.iter().enumerate() {
            assert_eq!(score_designs(&net, std::slice::from_ref(d), &settings(), &streams), [scores[i].clone()]);
        }
    }

    /// A design listed twice ties and the tie goes to the first; a policy that never reaches
    /// the destination loops and ranks last, however little its capped episodes cost.
    #[test]
    fn ties_go_to_the_first_design_and_a_looping_policy_ranks_last() {
        let net = tiny();
        let action = policy(&net);
        let zeta: Vec<f64> = net.instance().users[..3].iter().flat_map(|u| [u[0], u[1]]).collect();
        let streams = Streams::new(5);
        let twice = vec![(zeta.clone(), action.clone()), (zeta.clone(), action.clone())];
        let (best, scores) = rank_designs(&net, &twice, &settings(), &streams);
        assert_eq!(best, 0);
        assert_eq!(scores[0], scores[1]);
        // UAVs 0 and 1 send to each other: every user's packet circles until the cap.
        let mut looping = action.clone();
        let (u0, u1) = (net.n_users(), net.n_users() + 1);
        looping[u0] = 1;
        looping[u1] = 0;
        let (best, scores) = rank_designs(&net, &[(zeta.clone(), looping), (zeta, action)], &settings(), &streams);
        assert!(scores[0].loops && !scores[1].loops, "{scores:?}");
        assert_eq!(best, 1);
    }
}
