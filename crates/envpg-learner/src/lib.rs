//! # envpg-learner
//!
//! The learner: a thin process shell around [`envpg_ac::Learner::update`].
//!
//! For each iteration k, [`run_learner`] broadcasts (θ_k, ζ_k, α_k), hands out the iteration's
//! episode ids to the live workers, and blocks in a WaitSet until every episode has arrived. It
//! then orders them by (kind, index) — so the update is the same whichever worker ran what —
//! updates, records the history, and checkpoints on schedule. After the last iteration the
//! workers are told to stop and the result file is written by the same
//! [`envpg_ac::trainer::Recorder::finish`] as in one process, which also runs the ζ polish
//! (`polish_iterations`) here, in the learner process, on two threads.
//!
//! Faults: a worker that stops heartbeating (or is replaced: a new incarnation in its slot, or
//! says goodbye) loses its unfinished episodes to the others; late or duplicate episodes are
//! dropped, so nothing is lost or counted twice. Episodes from another run, iteration or
//! protocol version, of the wrong shape, or carrying states or actions out of range or
//! non-finite costs ([`episode_from`]) are refused and counted.
//!
//! A learner and one worker thread on one run, over the process-local iceoryx2 service:
//!
//! ```
//! use std::time::Duration;
//! use envpg_ac::{AcConfig, trainer::{RunSpec, train}};
//! use envpg_learner::{LearnerConfig, run_learner};
//! use envpg_worker::{WorkerConfig, run_worker};
//!
//! let registry = envpg_envs::registry();
//! let env = registry.load("flpo-n10m4", &[])?;
//! let config = AcConfig { iterations: 5, episodes: 8, explore_episodes: 4, hidden: vec![16], batch: 64,
//!     warmup: 2, eval_every: 5, polish_iterations: 0, ..AcConfig::default() };
//! let spec = RunSpec::new(&env, 3, config);
//! let (run_id, secs) = (String::from("doc-run"), Duration::from_secs);
//! let learner = LearnerConfig { run_id: run_id.clone(), spec: spec.clone(), env: env.clone(), max_workers: 1,
//!     worker_timeout: secs(10), checkpoint: None, resume: None, stall_timeout: secs(60), collect_only: false };
//! let worker = WorkerConfig { run_id, spec: spec.clone(), env, worker_id: 0, incarnation: 1,
//!     protocol: envpg_protocol::PROTOCOL_VERSION, join_timeout: secs(10), heartbeat: Duration::from_millis(100),
//!     emulator_cost_us: 0, run_over: None };
//! let worker = std::thread::spawn(move || run_worker::<envpg_transport::local::Service>(&worker));
//! let (result, stats) = run_learner::<envpg_transport::local::Service>(&learner, |_| true)?;
//! worker.join().unwrap()?;
//! assert_eq!((stats.episodes, stats.refused), (5 * (8 + 4), 0));
//! // The seed alone decides the run: bitwise the serial trainer's result.
//! let serial = train(&spec, &registry, |_| true)?;
//! assert_eq!((result.zeta, result.policy), (serial.zeta, serial.policy));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod assign;

use std::collections::{BTreeMap, BTreeSet};
use std::path::PathBuf;
use std::time::{Duration, Instant};

use envpg_ac::learner::{Batch, LearnerState};
use envpg_ac::rollout::{Episode, episode_ids};
use envpg_ac::trainer::{Progress, Recorder, RunSpec, TrainError};
use envpg_core::{LoadedEnv, ResultFile};
use envpg_protocol::{Checkpoint, EpisodeHeader, EpisodeId, PROTOCOL_VERSION, StepRecord, hello_kind, run_id_bytes};
use envpg_transport::{LearnerEnd, LinkSizes, TransportError};
use iceoryx2::prelude::*;
use iceoryx2::waitset::WaitSetRunResult;

pub use assign::Assignments;

/// Where and how often to checkpoint. Besides every `every` iterations, the learner always
/// checkpoints when it is stopped (SIGINT/SIGTERM, or the progress callback) and once training
/// ends, before the polish: an interrupted run resumes from its last completed iteration.
#[derive(Debug, Clone)]
pub struct CheckpointPolicy {
    /// The checkpoint file (written atomically).
    pub path: PathBuf,
    /// Every this many iterations (0: only when stopped and at the end of training).
    pub every: u64,
}

/// How the learner is started.
#[derive(Debug, Clone)]
pub struct LearnerConfig {
    /// Run id (names the services).
    pub run_id: String,
    /// The run.
    pub spec: RunSpec,
    /// The run's environment, built from `spec`'s instance.
    pub env: LoadedEnv,
    /// Most workers alive at once (sizes the services).
    pub max_workers: usize,
    /// A worker silent for this long is presumed dead.
    pub worker_timeout: Duration,
    /// Checkpointing, if any.
    pub checkpoint: Option<CheckpointPolicy>,
    /// State to continue from.
    pub resume: Option<Checkpoint>,
    /// Stop (with an error) if no episode arrives for this long while workers are needed.
    pub stall_timeout: Duration,
    /// Benchmark mode: collect every iteration's episodes but never update (weights and ζ
    /// stay at their initial values), to measure rollouts and transport alone.
    pub collect_only: bool,
}

/// Counters of the link, reported in the result file.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct LinkStats {
    /// Episode messages accepted.
    pub episodes: u64,
    /// Transitions in the accepted episodes.
    pub transitions: u64,
    /// Duplicates (an episode already received) dropped.
    pub duplicates: u64,
    /// Messages for another iteration dropped.
    pub stale: u64,
    /// Messages refused (other run, version, an episode not handed to the worker it claims,
    /// shape, values out of range).
    pub refused: u64,
    /// Of those, episodes refused on their contents (shape, ranges, non-finite values): the
    /// first is logged as a warning, the rest only counted.
    pub refused_contents: u64,
    /// Workers declared dead (timeout, replacement or goodbye with work outstanding).
    pub workers_lost: u64,
    /// Episodes handed out again after a worker was lost.
    pub reassigned: u64,
    /// Workers that refused the run for a protocol mismatch.
    pub protocol_refusals: u64,
}

/// Why the learner stopped.
#[derive(Debug, thiserror::Error)]
pub enum LearnerError {
    /// The link failed.
    #[error(transparent)]
    Transport(#[from] TransportError),
    /// The algorithm failed (bad settings, refused batch).
    #[error(transparent)]
    Train(#[from] TrainError),
    /// A checkpoint could not be used.
    #[error("checkpoint: {0}")]
    Checkpoint(String),
    /// The WaitSet failed.
    #[error("waiting for events: {0}")]
    Wait(String),
    /// SIGINT/SIGTERM.
    #[error("terminated by signal at iteration {0}")]
    Terminated(u64),
    /// No worker produced anything for too long.
    #[error("no episode arrived for {seconds:.0} s at iteration {k} ({pending} pending, {live} live workers)")]
    Stalled {
        /// Iteration.
        k: u64,
        /// Seconds waited.
        seconds: f64,
        /// Episodes still missing.
        pending: usize,
        /// Live workers.
        live: usize,
    },
    /// Every worker refused the run's protocol version.
    #[error("worker {worker} speaks protocol version {worker_version}, this learner speaks version {learner_version}")]
    Protocol {
        /// Worker slot.
        worker: u32,
        /// The worker's version.
        worker_version: u32,
        /// Ours.
        learner_version: u32,
    },
    /// The progress callback asked to stop.
    #[error("stopped at iteration {0}")]
    Stopped(u64),
}

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
pub fn episode_from(h: &EpisodeHeader, recs: &[StepRecord], shape: &EpisodeShape) -> Result<Episode, String> {
    let (d, cap) = (shape.zeta_dim, shape.cap);
    if h.zeta_dim as usize != d {
        return Err(format!("ζ dimension {} instead of {d}", h.zeta_dim));
    }
    if recs.len() != h.len as usize || recs.len() > cap || recs.is_empty() {
        return Err(format!("{} records (header says {}, cap {cap})", recs.len(), h.len));
    }
    if h.capped > 1 {
        return Err(format!("capped flag {}", h.capped));
    }
    for (t, r) in recs.iter().enumerate() {
        let (s, a, s2) = (r.s as usize, r.a as usize, r.s2 as usize);
        if s >= shape.n_states || s2 >= shape.n_states || a >= shape.n_actions {
            return Err(format!(
                "step {t}: (s, a, s') = ({s}, {a}, {s2}) outside {} states and {} actions",
                shape.n_states, shape.n_actions
            ));
        }
        if !r.cost.is_finite() || r.zeta[..d].iter().any(|z| !z.is_finite()) {
            return Err(format!("step {t}: a cost or ζ coordinate is not finite"));
        }
    }
    let mut ep =
        Episode { index: h.episode.index, explore: h.episode.kind != 0, capped: h.capped != 0, ..Default::default() };
    for r in recs {
        ep.s.push(r.s);
        ep.a.push(r.a);
        ep.s2.push(r.s2);
        ep.cost.push(r.cost);
        ep.zeta.extend_from_slice(&r.zeta[..d]);
    }
    Ok(ep)
}

fn episode_id(kind: envpg_ac::EpisodeKind, index: u64) -> EpisodeId {
    EpisodeId { kind: u32::from(kind == envpg_ac::EpisodeKind::Explore), index: index as u32 }
}

/// Runs the learner until the last iteration; returns the result file (not yet written).
pub fn run_learner<S: Service>(
    cfg: &LearnerConfig,
    mut progress: impl FnMut(&Progress) -> bool,
) -> Result<(ResultFile, LinkStats), LearnerError>
where
    iceoryx2::port::listener::Listener<S>: SynchronousMultiplexing,
{
    let spec = &cfg.spec;
    let (zeta0, mut learner) = spec.start_on(&cfg.env)?;
    if zeta0.len() > envpg_protocol::MAX_ZETA {
        return Err(LearnerError::Train(TrainError::Zeta0(format!(
            "ζ has {} coordinates; the distributed protocol carries at most {}",
            zeta0.len(),
            envpg_protocol::MAX_ZETA
        ))));
    }
    let mut rec = Recorder::new(spec, &cfg.env, &zeta0);
    if let Some(c) = &cfg.resume {
        let st: LearnerState = postcard::from_bytes(&c.learner).map_err(|e| LearnerError::Checkpoint(e.to_string()))?;
        learner.restore(st).map_err(LearnerError::Checkpoint)?;
        let history = serde_json::from_str(&c.history_json).map_err(|e| LearnerError::Checkpoint(e.to_string()))?;
        rec.resume(history, c.transitions, c.capped);
        rec.add_seconds(c.seconds);
    }
    let d = zeta0.len();
    let ids: Vec<EpisodeId> = episode_ids(&spec.config).map(|(kind, e)| episode_id(kind, e)).collect();
    let sizes = LinkSizes {
        max_workers: cfg.max_workers,
        n_params: learner.actor().n_params(),
        episode_cap: learner.config().episode_cap,
        episodes_per_iteration: ids.len(),
    };
    let end = LearnerEnd::<S>::create(&cfg.run_id, sizes)?;
    end.announce(d, false)?;
    // Whatever ends this function, workers are told the run is over.
    let _finish = Finish { end: &end, zeta_dim: d };
    let waitset = WaitSetBuilder::new()
        .signal_handling_mode(SignalHandlingMode::HandleTerminationRequests)
        .create::<S>()
        .map_err(|e| LearnerError::Wait(format!("{e:?}")))?;
    let _wake = waitset.attach_notification(end.listener()).map_err(|e| LearnerError::Wait(format!("{e:?}")))?;
    // Late joiners only get the run info and weights once the publishers refresh their
    // connections, so tick often.
    let tick = (cfg.worker_timeout / 4).clamp(Duration::from_millis(5), Duration::from_millis(50));
    let _tick = waitset.attach_interval(tick).map_err(|e| LearnerError::Wait(format!("{e:?}")))?;

    let run_id = run_id_bytes(&cfg.run_id);
    let shape = EpisodeShape {
        zeta_dim: d,
        cap: learner.config().episode_cap,
        n_states: cfg.env.sampler().n_states(),
        n_actions: cfg.env.sampler().n_actions(),
    };
    let mut stats = LinkStats::default();
    let mut workers = Assignments::new(cfg.worker_timeout);
    let mut last_refusal: Option<(u32, u32, Instant)> = None;
    let mut k = learner.k();
    while (k as usize) < spec.config.iterations {
        let zeta_k = learner.zeta().to_vec();
        end.publish_weights(k, learner.alpha(), &zeta_k, learner.actor().params())?;
        let mut done: BTreeMap<EpisodeId, Episode> = BTreeMap::new();
        workers.start_iteration(k, &ids);
        workers.dispatch(&end)?;
        end.notify_workers()?;
        let mut last_arrival = Instant::now();
        while done.len() < ids.len() {
            let r = waitset
                .wait_and_process_once_with_timeout(|_| CallbackProgression::Continue, tick)
                .map_err(|e| LearnerError::Wait(format!("{e:?}")))?;
            if matches!(r, WaitSetRunResult::TerminationRequest | WaitSetRunResult::Interrupt) {
                let _ = end.announce(d, true);
                // The iteration in flight is dropped; the k completed ones are kept.
                write_checkpoint(cfg, &learner.state(), &rec)?;
                return Err(LearnerError::Terminated(k));
            }
            end.drain_wakeups();
            end.refresh();
            for h in end.receive_hellos()? {
                if h.magic != envpg_protocol::MAGIC || h.run_id != run_id {
                    stats.refused += 1;
                    continue;
                }
                match h.kind {
                    hello_kind::REFUSE => {
                        stats.protocol_refusals += 1;
                        last_refusal = Some((h.worker_id, h.protocol, Instant::now()));
                        tracing::error!(
                            "worker {} refused the run: it speaks protocol version {}, this learner speaks version {PROTOCOL_VERSION}",
                            h.worker_id,
                            h.protocol
                        );
                    }
                    _ if h.protocol != PROTOCOL_VERSION => stats.refused += 1,
                    hello_kind::JOIN => {
                        stats.workers_lost += workers.join(h.worker_id, h.incarnation, &mut stats.reassigned)
                    }
                    hello_kind::HEARTBEAT => workers.heartbeat(h.worker_id, h.incarnation),
                    hello_kind::LEAVE => {
                        stats.workers_lost += workers.leave(h.worker_id, h.incarnation, &mut stats.reassigned)
                    }
                    _ => stats.refused += 1,
                }
            }
            end.receive_episodes(|h, recs| {
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
                match episode_from(h, recs, &shape) {
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
            let lost = workers.expire(&mut stats.reassigned);
            if lost > 0 {
                stats.workers_lost += lost;
                end.cleanup_dead_nodes();
            }
            workers.dispatch(&end)?;
            end.notify_workers()?;
            // Workers that refused our protocol are not coming back: with nobody else to do the
            // work, say so instead of waiting out the stall timeout.
            if let (Some((worker, v, when)), 0) = (last_refusal, workers.live())
                && when.elapsed() > cfg.worker_timeout
            {
                return Err(LearnerError::Protocol { worker, worker_version: v, learner_version: PROTOCOL_VERSION });
            }
            if done.len() < ids.len() && last_arrival.elapsed() > cfg.stall_timeout {
                return Err(LearnerError::Stalled {
                    k,
                    seconds: last_arrival.elapsed().as_secs_f64(),
                    pending: ids.len() - done.len(),
                    live: workers.live(),
                });
            }
        }
        if cfg.collect_only {
            k += 1;
            continue;
        }
        let mut table = learner.policy_table();
        let episodes: Vec<Episode> = done.into_values().collect();
        let st = learner.update(&Batch { k, episodes }).map_err(TrainError::from)?;
        let p = rec.record(&zeta_k, &mut table, &st);
        let every = cfg.checkpoint.as_ref().map_or(0, |cp| cp.every);
        if (every > 0 && learner.k() % every == 0) || learner.k() as usize == spec.config.iterations {
            write_checkpoint(cfg, &learner.state(), &rec)?;
        }
        if !progress(&p) {
            let _ = end.announce(d, true);
            write_checkpoint(cfg, &learner.state(), &rec)?;
            return Err(LearnerError::Stopped(learner.k()));
        }
        k = learner.k();
    }
    end.announce(d, true)?;
    let details = serde_json::json!({ "mode": "workers", "link": stats });
    // A collect-only run measures rollouts and transport: its result is not polished.
    let result = if cfg.collect_only {
        rec.finish_unpolished(&learner, "envpg-ac", details)
    } else {
        rec.finish(&learner, "envpg-ac", details)
    };
    Ok((result, stats))
}

/// Announces the end of the run when dropped.
struct Finish<'a, S: Service> {
    end: &'a LearnerEnd<S>,
    zeta_dim: usize,
}

impl<S: Service> Drop for Finish<'_, S> {
    fn drop(&mut self) {
        let _ = self.end.announce(self.zeta_dim, true);
    }
}

/// Writes the checkpoint of `cfg`, if it has one.
fn write_checkpoint(cfg: &LearnerConfig, st: &LearnerState, rec: &Recorder) -> Result<(), LearnerError> {
    let Some(cp) = &cfg.checkpoint else { return Ok(()) };
    let spec = &cfg.spec;
    let c = Checkpoint {
        protocol: PROTOCOL_VERSION,
        run_id: cfg.run_id.clone(),
        k: st.k,
        spec_json: serde_json::to_string(spec).map_err(|e| LearnerError::Checkpoint(e.to_string()))?,
        learner: postcard::to_stdvec(st).map_err(|e| LearnerError::Checkpoint(e.to_string()))?,
        history_json: serde_json::to_string(rec.history()).map_err(|e| LearnerError::Checkpoint(e.to_string()))?,
        transitions: rec.transitions(),
        capped: rec.capped(),
        seconds: rec.seconds(),
    };
    envpg_core::io::write_atomic(&cp.path, &c.to_bytes())
        .map_err(|e| LearnerError::Checkpoint(format!("{}: {e}", cp.path.display())))
}

/// Reads the set of episode ids of an iteration (for tests and tools).
pub fn iteration_ids(spec: &RunSpec) -> BTreeSet<EpisodeId> {
    episode_ids(&spec.config).map(|(kind, e)| episode_id(kind, e)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn message(n: usize) -> (EpisodeHeader, Vec<StepRecord>) {
        let h = EpisodeHeader { len: n as u32, zeta_dim: 2, ..Default::default() };
        let r = StepRecord { s: 1, a: 0, s2: 2, cost: 0.5, zeta: [0.25; envpg_protocol::MAX_ZETA] };
        (h, vec![r; n])
    }

    const SHAPE: EpisodeShape = EpisodeShape { zeta_dim: 2, cap: 8, n_states: 3, n_actions: 2 };

    #[test]
    fn well_formed_episodes_are_accepted() {
        let (h, recs) = message(4);
        let ep = episode_from(&h, &recs, &SHAPE).unwrap();
        assert_eq!((ep.len(), ep.zeta.len()), (4, 8));
    }

    #[test]
    fn every_kind_of_malformed_episode_is_refused_with_its_reason() {
        type Break = Box<dyn Fn(&mut EpisodeHeader, &mut Vec<StepRecord>)>;
        let cases: Vec<(&str, Break)> = vec![
            ("records", Box::new(|h, _| h.len = 5)),
            (
                "records",
                Box::new(|h, r| {
                    r.extend(r.clone().iter().cycle().take(6));
                    h.len = r.len() as u32;
                }),
            ),
            (
                "records",
                Box::new(|h, r| {
                    r.clear();
                    h.len = 0;
                }),
            ),
            ("dimension", Box::new(|h, _| h.zeta_dim = 64)),
            ("outside", Box::new(|_, r| r[2].s = 3)),
            ("outside", Box::new(|_, r| r[0].s2 = u32::MAX)),
            ("outside", Box::new(|_, r| r[3].a = 2)),
            ("not finite", Box::new(|_, r| r[1].cost = f32::NAN)),
            ("not finite", Box::new(|_, r| r[1].cost = f32::INFINITY)),
            ("not finite", Box::new(|_, r| r[0].zeta[1] = f32::NEG_INFINITY)),
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
