//! Rollouts: the worker side of Algorithm 1. An episode touches the environment only through
//! its sampler ([`ParamMdp::sample_initial`], [`ParamMdp::step`], …); every draw comes from the
//! episode's own stream `(seed, k, e)`, so it is the same whoever runs it. Each step's
//! perturbed design ζ_k + N(0, σ²I) is projected onto the design bounds, so the environment
//! only ever sees designs inside them.

use envpg_core::{ParamMdp, Purpose, Streams};
use rand::{Rng, RngExt};
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

use crate::config::AcConfig;
use crate::nets::ActionSets;
use crate::table::PolicyTable;

/// Why an episode was generated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum EpisodeKind {
    /// From μ with actions from π_θk at ζ_k: used for everything, including the ζ-gradient.
    OnPolicy,
    /// ε-mixed behaviour and exploring starts: used only to train critic and actor.
    Explore,
}

/// The transitions of one episode, as parallel arrays.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Episode {
    /// Episode index e within its kind.
    pub index: u32,
    /// Whether on-policy (`false`: exploration).
    pub explore: bool,
    /// States s_t.
    pub s: Vec<u32>,
    /// Actions a_t.
    pub a: Vec<u32>,
    /// Successors s_{t+1}.
    pub s2: Vec<u32>,
    /// Costs c_t.
    pub cost: Vec<f32>,
    /// Perturbed designs ζ_pert of each step, `len × d`.
    pub zeta: Vec<f32>,
    /// Whether the episode hit the length cap before terminating.
    pub capped: bool,
}

impl Episode {
    /// Number of transitions.
    pub fn len(&self) -> usize {
        self.s.len()
    }
    /// Whether empty.
    pub fn is_empty(&self) -> bool {
        self.s.is_empty()
    }
    /// The episode's kind.
    pub fn kind(&self) -> EpisodeKind {
        if self.explore { EpisodeKind::Explore } else { EpisodeKind::OnPolicy }
    }
}

/// The RNG stream of episode `(k, e)` of `kind`.
pub fn episode_stream(streams: &Streams, kind: EpisodeKind, k: u64, e: u64) -> envpg_core::rng::StreamRng {
    let purpose = match kind {
        EpisodeKind::OnPolicy => Purpose::Episode,
        EpisodeKind::Explore => Purpose::Explore,
    };
    streams.stream(purpose, k, e)
}

/// Samples from `probs` with one uniform draw.
#[inline]
pub fn sample_index<R: Rng + ?Sized>(probs: &[f64], rng: &mut R) -> usize {
    let mut u: f64 = rng.random();
    for (i, &p) in probs.iter().enumerate() {
        if u < p {
            return i;
        }
        u -= p;
    }
    // Rounding left u ≥ Σp: take the last action with positive probability.
    probs.iter().rposition(|&p| p > 0.0).unwrap_or(probs.len() - 1)
}

/// Runs episode `(k, e)` of `kind` at design `zeta_k` with policy `table`.
#[allow(clippy::too_many_arguments)]
pub fn run_episode<E: ParamMdp + ?Sized>(
    env: &E,
    sets: &ActionSets,
    table: &mut PolicyTable,
    zeta_k: &[f64],
    cfg: &AcConfig,
    streams: &Streams,
    kind: EpisodeKind,
    k: u64,
    e: u64,
) -> Episode {
    let mut rng = episode_stream(streams, kind, k, e);
    let d = zeta_k.len();
    let explore = kind == EpisodeKind::Explore;
    let mut ep = Episode { index: e as u32, explore, ..Default::default() };
    let mut s = if explore && rng.random::<f64>() < cfg.explore_start {
        env.sample_exploring_start(&mut rng)
    } else {
        env.sample_initial(&mut rng)
    };
    let mut zeta = vec![0.0; d];
    let sigma = cfg.sigma_at(k);
    let space = env.zeta_space();
    let bounded = space.is_bounded();
    for _ in 0..cfg.episode_cap {
        let actions = sets.of(s);
        let k_a = if explore && rng.random::<f64>() < cfg.explore_eps {
            rng.random_range(0..actions.len())
        } else {
            sample_index(table.of(s), &mut rng)
        };
        let a = actions[k_a];
        for (z, zk) in zeta.iter_mut().zip(zeta_k) {
            let n: f64 = rng.sample(StandardNormal);
            *z = zk + sigma * n;
        }
        if bounded {
            space.project(&mut zeta);
        }
        let (s2, c) = env.step(s, a, &zeta, &mut rng);
        ep.s.push(s as u32);
        ep.a.push(a as u32);
        ep.s2.push(s2 as u32);
        ep.cost.push(c as f32);
        ep.zeta.extend(zeta.iter().map(|&z| z as f32));
        if env.is_terminal(s2) {
            return ep;
        }
        s = s2;
    }
    ep.capped = true;
    ep
}

/// Runs all episodes of iteration `k` in index order: `cfg.episodes` on-policy, then
/// `cfg.explore_episodes` exploration episodes.
pub fn run_iteration<E: ParamMdp + ?Sized>(
    env: &E,
    sets: &ActionSets,
    table: &mut PolicyTable,
    zeta_k: &[f64],
    cfg: &AcConfig,
    streams: &Streams,
    k: u64,
) -> Vec<Episode> {
    episode_ids(cfg).map(|(kind, e)| run_episode(env, sets, table, zeta_k, cfg, streams, kind, k, e)).collect()
}

/// The episodes of one iteration, in the order the learner consumes them.
pub fn episode_ids(cfg: &AcConfig) -> impl Iterator<Item = (EpisodeKind, u64)> + use<> {
    let on = (0..cfg.episodes as u64).map(|e| (EpisodeKind::OnPolicy, e));
    let ex = (0..cfg.explore_episodes as u64).map(|e| (EpisodeKind::Explore, e));
    on.chain(ex)
}
