//! [`Link`]: the learner's side of one iteration's exchange with the workers — hand out the
//! episodes, keep track of who is alive, take in what arrives — and [`episode_from`], the
//! check every received episode passes.
//!
//! The link knows nothing of the algorithm: it is handed the iteration k whose episodes to
//! gather and returns them ordered by (kind, index), so the update that follows does not
//! depend on which worker ran what, nor on when they arrived. With a policy lag the learner
//! updates on another thread while the link gathers.

use std::collections::BTreeMap;
use std::time::{Duration, Instant};

use envpg_ac::rollout::Episode;
use envpg_protocol::{EpisodeHeader, EpisodeId, PROTOCOL_VERSION, hello_kind, read_step, step_words};
use envpg_transport::LearnerEnd;
use iceoryx2::prelude::*;
use iceoryx2::waitset::{WaitSet, WaitSetRunResult};

use crate::{Assignments, LearnerConfig, LearnerError, LinkStats};

/// What a well-formed episode message of this run looks like.
#[derive(Debug, Clone, Copy)]
pub struct EpisodeShape {
    /// Dimension of ζ.
    pub zeta_dim: usize,
    /// Most records per episode.
    pub cap: usize,
    /// States are `0..n_states`.
    pub n_states: usize,
    /// Actions are `0..n_actions`.
    pub n_actions: usize,
}

/// Converts a received episode message to an [`Episode`], checking everything it carries: its
/// shape, every state and action in range, every cost and perturbed ζ finite. A malformed
/// message (a broken or hostile peer) is refused whole, with the reason.
pub fn episode_from(h: &EpisodeHeader, words: &[u32], shape: &EpisodeShape) -> Result<Episode, String> {
    let (d, cap) = (shape.zeta_dim, shape.cap);
    if h.zeta_dim as usize != d {
        return Err(format!("ζ dimension {} instead of {d}", h.zeta_dim));
    }
    let w = step_words(d);
    let n = h.len as usize;
    if words.len() != n * w || n > cap || n == 0 {
        return Err(format!("{} words for {n} records of {w} words (cap {cap} records)", words.len()));
    }
    if h.capped > 1 {
        return Err(format!("capped flag {}", h.capped));
    }
    let mut ep = Episode {
        index: h.episode.index,
        explore: h.episode.kind != 0,
        capped: h.capped != 0,
        zeta: Vec::with_capacity(n * d),
        ..Default::default()
    };
    for (t, rec) in words.chunks_exact(w).enumerate() {
        let (r, zeta) = read_step(rec);
        let (s, a, s2) = (r.s as usize, r.a as usize, r.s2 as usize);
        if s >= shape.n_states || s2 >= shape.n_states || a >= shape.n_actions {
            return Err(format!(
                "step {t}: (s, a, s') = ({s}, {a}, {s2}) outside {} states and {} actions",
                shape.n_states, shape.n_actions
            ));
        }
        let at = ep.zeta.len();
        ep.zeta.extend(zeta);
        if !r.cost.is_finite() || ep.zeta[at..].iter().any(|z| !z.is_finite()) {
            return Err(format!("step {t}: a cost or ζ coordinate is not finite"));
        }
        ep.s.push(r.s);
        ep.a.push(r.a);
        ep.s2.push(r.s2);
        ep.cost.push(r.cost);
    }
    Ok(ep)
}

/// How gathering an iteration's episodes ended.
pub(crate) enum Collected {
    /// Every episode of the iteration, ordered by (kind, index).
    Batch(Vec<Episode>),
    /// SIGINT/SIGTERM arrived first: the iteration's episodes are dropped.
    Terminated,
}

/// The learner's end of the exchange with the workers, over the whole run.
pub(crate) struct Link<'a, S: Service> {
    pub cfg: &'a LearnerConfig,
    pub end: &'a LearnerEnd<S>,
    pub waitset: &'a WaitSet<S>,
    /// The WaitSet's interval: how often liveness and stalls are looked at.
    pub tick: Duration,
    /// The episodes of every iteration, in batch order.
    pub ids: &'a [EpisodeId],
    pub shape: EpisodeShape,
    pub run_id: envpg_protocol::RunId,
    pub stats: LinkStats,
    pub workers: Assignments,
    /// The last worker that refused the run's protocol, its version, and when.
    pub last_refusal: Option<(u32, u32, Instant)>,
}

impl<S: Service> Link<'_, S>
where
    iceoryx2::port::listener::Listener<S>: SynchronousMultiplexing,
{
    /// Hands iteration k's episodes to the live workers (its weights are already published)
    /// and waits until every one has arrived, refusing anything malformed or not asked for.
    pub fn collect(&mut self, k: u64) -> Result<Collected, LearnerError> {
        let (end, ids, run_id) = (self.end, self.ids, self.run_id);
        let mut done: BTreeMap<EpisodeId, Episode> = BTreeMap::new();
        self.workers.start_iteration(k, ids);
        self.workers.dispatch(end)?;
        end.notify_workers()?;
        let mut last_arrival = Instant::now();
        while done.len() < ids.len() {
            let r = self
                .waitset
                .wait_and_process_once_with_timeout(|_| CallbackProgression::Continue, self.tick)
                .map_err(|e| LearnerError::Wait(format!("{e:?}")))?;
            if matches!(r, WaitSetRunResult::TerminationRequest | WaitSetRunResult::Interrupt) {
                return Ok(Collected::Terminated);
            }
            end.drain_wakeups();
            end.refresh();
            self.take_hellos()?;
            let (stats, workers, shape) = (&mut self.stats, &mut self.workers, &self.shape);
            end.receive_episodes(|h, words| {
                if h.protocol != PROTOCOL_VERSION || h.run_id != run_id {
                    stats.refused += 1;
                    return;
                }
                if h.k != k {
                    stats.stale += 1;
                    return;
                }
                if !ids.contains(&h.episode) || !workers.was_handed(&h.episode, h.worker_id) {
                    stats.refused += 1;
                    return;
                }
                let std::collections::btree_map::Entry::Vacant(slot) = done.entry(h.episode) else {
                    stats.duplicates += 1;
                    return;
                };
                match episode_from(h, words, shape) {
                    Ok(ep) => {
                        workers.completed(&h.episode);
                        stats.transitions += ep.len() as u64;
                        slot.insert(ep);
                        stats.episodes += 1;
                        last_arrival = Instant::now();
                    }
                    Err(reason) => {
                        // The first is a warning; the rest are counted, so a flood of bad
                        // episodes cannot flood the log (or block on a full stderr pipe).
                        if stats.refused_contents == 0 {
                            tracing::warn!(
                                "refusing episode {:?} from worker {}: {reason} (further ones are counted in the result's details)",
                                h.episode,
                                h.worker_id
                            );
                        } else {
                            tracing::debug!("refusing episode {:?} from worker {}: {reason}", h.episode, h.worker_id);
                        }
                        stats.refused_contents += 1;
                        stats.refused += 1;
                    }
                }
            })?;
            let lost = self.workers.expire(&mut self.stats.reassigned);
            if lost > 0 {
                self.stats.workers_lost += lost;
                end.cleanup_dead_nodes();
            }
            self.workers.dispatch(end)?;
            end.notify_workers()?;
            // Workers that refused our protocol are not coming back: with nobody else to do the
            // work, say so instead of waiting out the stall timeout.
            if let (Some((worker, v, when)), 0) = (self.last_refusal, self.workers.live())
                && when.elapsed() > self.cfg.worker_timeout
            {
                return Err(LearnerError::Protocol { worker, worker_version: v, learner_version: PROTOCOL_VERSION });
            }
            if done.len() < ids.len() && last_arrival.elapsed() > self.cfg.stall_timeout {
                return Err(LearnerError::Stalled {
                    k,
                    seconds: last_arrival.elapsed().as_secs_f64(),
                    pending: ids.len() - done.len(),
                    live: self.workers.live(),
                });
            }
        }
        Ok(Collected::Batch(done.into_values().collect()))
    }

    /// Joins, heartbeats, goodbyes and protocol refusals of workers.
    fn take_hellos(&mut self) -> Result<(), LearnerError> {
        for h in self.end.receive_hellos()? {
            if h.magic != envpg_protocol::MAGIC || h.run_id != self.run_id {
                self.stats.refused += 1;
                continue;
            }
            let stats = &mut self.stats;
            match h.kind {
                hello_kind::REFUSE => {
                    stats.protocol_refusals += 1;
                    self.last_refusal = Some((h.worker_id, h.protocol, Instant::now()));
                    tracing::error!(
                        "worker {} refused the run: it speaks protocol version {}, this learner speaks version {PROTOCOL_VERSION}",
                        h.worker_id,
                        h.protocol
                    );
                }
                _ if h.protocol != PROTOCOL_VERSION => stats.refused += 1,
                hello_kind::JOIN => {
                    stats.workers_lost += self.workers.join(h.worker_id, h.incarnation, &mut stats.reassigned)
                }
                hello_kind::HEARTBEAT => self.workers.heartbeat(h.worker_id, h.incarnation),
                hello_kind::LEAVE => {
                    stats.workers_lost += self.workers.leave(h.worker_id, h.incarnation, &mut stats.reassigned)
                }
                _ => stats.refused += 1,
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn message(n: usize) -> (EpisodeHeader, Vec<u32>) {
        let h = EpisodeHeader { len: n as u32, zeta_dim: 2, ..Default::default() };
        let mut words = vec![0u32; n * step_words(2)];
        for rec in words.chunks_exact_mut(step_words(2)) {
            envpg_protocol::write_step(rec, envpg_protocol::Step { s: 1, a: 0, s2: 2, cost: 0.5 }, &[0.25, 0.25]);
        }
        (h, words)
    }

    /// Word `i` of record `t` (0 s, 1 a, 2 s', 3 cost, 4.. ζ).
    fn word(t: usize, i: usize) -> usize {
        t * step_words(2) + i
    }

    const SHAPE: EpisodeShape = EpisodeShape { zeta_dim: 2, cap: 8, n_states: 3, n_actions: 2 };

    #[test]
    fn well_formed_episodes_are_accepted() {
        let (h, recs) = message(4);
        let ep = episode_from(&h, &recs, &SHAPE).unwrap();
        assert_eq!((ep.len(), ep.zeta.len()), (4, 8));
        assert_eq!((ep.s[3], ep.a[3], ep.s2[3], ep.cost[3], ep.zeta[7]), (1, 0, 2, 0.5, 0.25));
    }

    #[test]
    fn every_kind_of_malformed_episode_is_refused_with_its_reason() {
        type Break = Box<dyn Fn(&mut EpisodeHeader, &mut Vec<u32>)>;
        let cases: Vec<(&str, Break)> = vec![
            ("words", Box::new(|h, _| h.len = 5)),
            (
                "words",
                Box::new(|h, r| {
                    r.extend(r.clone().iter().cycle().take(6 * step_words(2)));
                    h.len = (r.len() / step_words(2)) as u32;
                }),
            ),
            (
                "words",
                Box::new(|h, r| {
                    r.clear();
                    h.len = 0;
                }),
            ),
            ("words", Box::new(|_, r| r.truncate(r.len() - 1))),
            ("dimension", Box::new(|h, _| h.zeta_dim = 64)),
            ("outside", Box::new(|_, r| r[word(2, 0)] = 3)),
            ("outside", Box::new(|_, r| r[word(0, 2)] = u32::MAX)),
            ("outside", Box::new(|_, r| r[word(3, 1)] = 2)),
            ("not finite", Box::new(|_, r| r[word(1, 3)] = f32::NAN.to_bits())),
            ("not finite", Box::new(|_, r| r[word(1, 3)] = f32::INFINITY.to_bits())),
            ("not finite", Box::new(|_, r| r[word(0, 5)] = f32::NEG_INFINITY.to_bits())),
            ("capped", Box::new(|h, _| h.capped = 7)),
        ];
        for (why, break_it) in cases {
            let (mut h, mut recs) = message(4);
            break_it(&mut h, &mut recs);
            let e = episode_from(&h, &recs, &SHAPE).expect_err(why);
            assert!(e.contains(why), "{why}: {e}");
        }
    }
}
