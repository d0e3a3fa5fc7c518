//! Sampled costs of a deterministic policy at a design, on common random numbers, and how the
//! polish compares them: a sample that loops (an SSP whose episodes run into the cap) loses to
//! any that does not, since a loop between two close points runs up little cost before the cap;
//! otherwise the lower mean wins — by at least `z` standard errors of the paired per-episode
//! differences when the polish asks for significance ([`PolishSettings::z`]).

use envpg_core::{ParamMdp, Purpose, StreamRng, Streams};

use super::{PolishSettings, on_two_threads};

/// The streams of episodes `0..n` of one polish iteration, primed once and cloned by every
/// design and policy sampled on them: the same words as fresh streams, without deriving their
/// keys and running the cipher again at each of the iteration's few dozen samples.
pub(super) struct Episodes<'a> {
    streams: &'a Streams,
    it: u64,
    n: usize,
    /// The first `min(n, MAX_PRIMED)` episodes' primed streams (the rest are made fresh).
    primed: Vec<StreamRng>,
}

/// Episodes whose primed streams are kept (~300 bytes each): a polish asked for millions of
/// episodes makes the rest afresh instead of holding gigabytes.
const MAX_PRIMED: usize = 1 << 15;

impl<'a> Episodes<'a> {
    /// Episodes `0..n` of polish iteration `it`.
    pub(super) fn new(streams: &'a Streams, it: u64, n: usize) -> Self {
        let primed = (0..n.min(MAX_PRIMED) as u64).map(|e| streams.primed_stream(Purpose::Polish, it, e)).collect();
        Self { streams, it, n, primed }
    }

    /// Episode `e`'s stream, from its start.
    fn stream(&self, e: usize) -> StreamRng {
        match self.primed.get(e) {
            Some(rng) => rng.clone(),
            None => self.streams.stream(Purpose::Polish, self.it, e as u64),
        }
    }
}

/// Mean cost of `episodes` at `zeta` under the deterministic policy `action` (one action per
/// state), and the number of steps taken.
pub(super) fn sampled_cost<E: ParamMdp + Sync + ?Sized>(
    env: &E,
    action: &[usize],
    zeta: &[f64],
    s: &PolishSettings,
    episodes: &Episodes<'_>,
) -> Sampled {
    let gamma = env.gamma();
    let mut out = Sampled {
        cost: 0.0,
        capped: 0,
        steps: 0,
        episodes: episodes.n as u64,
        ssp: gamma == 1.0,
        per_episode: Vec::with_capacity(if s.z > 0.0 { episodes.n } else { 0 }),
    };
    for e in 0..episodes.n {
        let mut rng = episodes.stream(e);
        let mut st = env.sample_initial(&mut rng);
        let mut done = false;
        let mut disc = 1.0;
        let mut episode = 0.0;
        for _ in 0..s.episode_cap {
            let (s2, c) = env.step(st, action[st], zeta, &mut rng);
            out.cost += disc * c;
            episode += disc * c;
            disc *= gamma;
            out.steps += 1;
            if env.is_terminal(s2) {
                done = true;
                break;
            }
            st = s2;
        }
        out.capped += u64::from(!done);
        if s.z > 0.0 {
            out.per_episode.push(episode);
        }
    }
    out.cost /= episodes.n as f64;
    out
}

/// The sampled cost of one (design, policy) on a set of episodes.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Sampled {
    /// Mean episode cost (capped episodes count with the cost they ran up).
    pub(super) cost: f64,
    /// Episodes that hit the length cap.
    pub(super) capped: u64,
    /// Environment steps taken.
    pub(super) steps: u64,
    /// Episodes sampled.
    pub(super) episodes: u64,
    /// Whether the environment is an SSP (γ = 1): only then does a capped episode mean a loop;
    /// with γ < 1 it is a truncation.
    pub(super) ssp: bool,
    /// Each episode's cost (kept only when comparisons ask for significance).
    pub(super) per_episode: Vec<f64>,
}

/// A sample loops when more than this fraction of its episodes hit the cap. A loop that even
/// one user of the 271 is routed into caps 1/271 of the episodes; with off-target moves, a
/// proper routing's rare long episodes cap a few in ten thousand.
pub(super) const LOOP_FRACTION: f64 = 1e-3;

impl Sampled {
    /// Whether the routing loops on these episodes.
    pub(super) fn loops(&self) -> bool {
        self.ssp && self.capped as f64 > LOOP_FRACTION * self.episodes as f64
    }

    /// Sort key: a routing that loops between two close UAVs runs up little cost before the
    /// cap and must not look cheap, so looping samples come last (fewer capped episodes
    /// first among them); the rest are ranked by cost.
    pub(super) fn key(&self) -> (bool, u64, f64) {
        (self.loops(), if self.loops() { self.capped } else { 0 }, self.cost)
    }

    /// The order of [`key`](Sampled::key): looping samples last, then by cost (a total order,
    /// for choosing the best of several samples).
    pub(super) fn rank(&self, other: &Sampled) -> std::cmp::Ordering {
        let (a, b) = (self.key(), other.key());
        a.0.cmp(&b.0).then(a.1.cmp(&b.1)).then(a.2.total_cmp(&b.2))
    }

    /// Whether this sample ranks before `other`.
    pub(super) fn beats(&self, other: &Sampled) -> bool {
        self.key().partial_cmp(&other.key()) == Some(std::cmp::Ordering::Less)
    }

    /// Whether this sample is better than `other`, drawn on the same episodes: it [`beats`] it,
    /// and — for `z > 0` and two samples that both loop or both do not — its mean is lower by
    /// at least `z` standard errors of the paired per-episode differences.
    ///
    /// [`beats`]: Sampled::beats
    pub(super) fn improves_on(&self, other: &Sampled, z: f64) -> bool {
        if !self.beats(other) {
            return false;
        }
        let n = self.per_episode.len();
        if z <= 0.0 || self.loops() != other.loops() || n < 2 || other.per_episode.len() != n {
            return true;
        }
        let d: Vec<f64> = other.per_episode.iter().zip(&self.per_episode).map(|(a, b)| a - b).collect();
        let mean = d.iter().sum::<f64>() / n as f64;
        let var = d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
        mean > z * (var / n as f64).sqrt()
    }
}

/// Sampled costs at each design, on two threads when there are designs enough; the values do
/// not depend on the thread count (each is computed whole by one thread).
pub(super) fn sampled_costs<E: ParamMdp + Sync + ?Sized>(
    env: &E,
    action: &[usize],
    designs: &[Vec<f64>],
    s: &PolishSettings,
    episodes: &Episodes<'_>,
) -> Vec<Sampled> {
    on_two_threads(designs, |z| sampled_cost(env, action, z, s, episodes))
}

/// Sampled costs of several policies at one design, on `episodes`.
pub(super) fn sampled_costs_of<E: ParamMdp + Sync + ?Sized>(
    env: &E,
    actions: &[&[usize]],
    zeta: &[f64],
    s: &PolishSettings,
    episodes: &Episodes<'_>,
) -> Vec<Sampled> {
    on_two_threads(actions, |a| sampled_cost(env, a, zeta, s, episodes))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(per_episode: &[f64], capped: u64, ssp: bool) -> Sampled {
        let n = per_episode.len() as u64;
        Sampled {
            cost: per_episode.iter().sum::<f64>() / n as f64,
            capped,
            steps: n,
            episodes: n,
            ssp,
            per_episode: per_episode.to_vec(),
        }
    }

    #[test]
    fn an_episodes_stream_is_its_fresh_stream_primed_or_past_the_primed_ones() {
        use rand::Rng;
        let streams = Streams::new(11);
        let episodes = Episodes::new(&streams, 5, MAX_PRIMED + 2);
        for e in [0, 1, MAX_PRIMED - 1, MAX_PRIMED, MAX_PRIMED + 1] {
            let (mut ours, mut fresh) = (episodes.stream(e), streams.stream(Purpose::Polish, 5, e as u64));
            for _ in 0..100 {
                assert_eq!(ours.next_u64(), fresh.next_u64(), "episode {e}");
            }
        }
    }

    #[test]
    fn a_lower_mean_improves_only_by_z_standard_errors_of_the_paired_differences() {
        let base = [10.0, 12.0, 9.0, 11.0, 10.5, 9.5];
        // Lower by exactly 0.1 on every episode: paired differences have no spread at all.
        let shifted: Vec<f64> = base.iter().map(|c| c - 0.1).collect();
        let (a, b) = (sample(&shifted, 0, true), sample(&base, 0, true));
        assert!(a.improves_on(&b, 3.0) && a.improves_on(&b, 100.0));
        // Lower by 0.1 on average but ±1 episode to episode: mean 0.1, SE = 1/√6 · √(6/5).
        let noisy: Vec<f64> =
            base.iter().enumerate().map(|(i, c)| c - 0.1 + if i % 2 == 0 { 1.0 } else { -1.0 }).collect();
        let a = sample(&noisy, 0, true);
        let se = (6.0f64 / 5.0 / 6.0).sqrt();
        assert!(a.beats(&b) && a.improves_on(&b, 0.0));
        assert!(a.improves_on(&b, 0.99 * 0.1 / se) && !a.improves_on(&b, 1.01 * 0.1 / se));
        // Higher is never an improvement.
        assert!(!b.improves_on(&a, 0.0));
    }

    #[test]
    fn a_sample_that_stops_looping_improves_whatever_its_spread() {
        // Four of six episodes capped: an SSP policy that loops, cheap only because it was cut.
        let looping = sample(&[1.0, 1.0, 1.0, 1.0, 30.0, 2.0], 4, true);
        let proper = sample(&[20.0, 5.0, 9.0, 40.0, 8.0, 11.0], 0, true);
        assert!(looping.loops() && !proper.loops());
        assert!(proper.improves_on(&looping, 10.0) && !looping.improves_on(&proper, 0.0));
        // With γ < 1 a capped episode is a truncation: the means decide.
        let (a, b) = (sample(&[1.0, 1.0, 1.0, 1.0, 30.0, 2.0], 4, false), sample(&[20.0; 6], 0, false));
        assert!(!a.loops() && a.improves_on(&b, 0.0) && !b.improves_on(&a, 0.0));
    }
}
