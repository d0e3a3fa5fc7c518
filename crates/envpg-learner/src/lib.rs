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
//! With a policy lag ([`envpg_ac::AcConfig::lag`] = 1) the learner overlaps: it broadcasts
//! θ_k, ζ_k, α_k for iteration k + 1 and gathers that batch on this thread while another
//! thread updates on batch k. The lag is fixed — batch k + 1 is always sampled with θ_k — so
//! the result is the serial trainer's, bit for bit, for any worker count.
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
//! use std::time::{Duration, Instant};
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
mod collect;

use std::collections::BTreeSet;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use envpg_ac::learner::{Batch, Learner, LearnerState};
use envpg_ac::rollout::{Episode, episode_ids};
use envpg_ac::trainer::{Progress, Recorder, RunSpec, TrainError};
use envpg_core::{LoadedEnv, ResultFile};
use envpg_protocol::{Checkpoint, EpisodeId, PROTOCOL_VERSION, run_id_bytes};
use envpg_transport::{LearnerEnd, LinkSizes, TransportError};
use iceoryx2::prelude::*;

pub use assign::Assignments;
use collect::{Collected, Link};
pub use collect::{EpisodeShape, episode_from};

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

/// Counters of the link, and the learner's own time, reported in the result file.
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
    /// Seconds spent in `Learner::update` (with a policy lag, on the thread beside the link).
    pub update_seconds: f64,
    /// CPU seconds of the learner process during the updates that ran alone (every update at
    /// lag 0, a lagged run's last): the update's own threads are all that run then, so over
    /// `update_alone_seconds` it is the number of cores the update keeps busy.
    pub update_cpu_seconds: f64,
    /// Wall seconds of the updates counted in `update_cpu_seconds`.
    pub update_alone_seconds: f64,
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
        restore_state(&mut learner, c)?;
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

    let shape = EpisodeShape {
        zeta_dim: d,
        cap: learner.config().episode_cap,
        n_states: cfg.env.sampler().n_states(),
        n_actions: cfg.env.sampler().n_actions(),
    };
    let mut link = Link {
        cfg,
        end: &end,
        waitset: &waitset,
        tick,
        ids: &ids,
        shape,
        run_id: run_id_bytes(&cfg.run_id),
        stats: LinkStats::default(),
        workers: Assignments::new(cfg.worker_timeout),
        last_refusal: None,
    };
    let total = spec.config.iterations as u64;
    // Stops the run on SIGINT/SIGTERM: the k completed iterations are kept, the one in flight
    // is dropped (a lagged run samples it again, with the same weights, when resumed).
    let terminated = |learner: &envpg_ac::Learner, rec: &Recorder| -> LearnerError {
        let _ = end.announce(d, true);
        match write_checkpoint(cfg, learner, rec) {
            Ok(()) => LearnerError::Terminated(learner.k()),
            Err(e) => e,
        }
    };
    if cfg.collect_only {
        // Rollouts and transport alone: every iteration sampled with the initial weights.
        for k in learner.k()..total {
            end.publish_weights(k, learner.alpha(), learner.zeta(), learner.actor().params())?;
            if let Collected::Terminated = link.collect(k)? {
                return Err(terminated(&learner, &rec));
            }
        }
        end.announce(d, true)?;
        let details = serde_json::json!({ "mode": "workers", "link": link.stats });
        return Ok((rec.finish_unpolished(&learner, "envpg-ac", details), link.stats));
    }
    // Records an update, checkpoints on schedule and reports progress.
    let mut after_update = |learner: &envpg_ac::Learner,
                            rec: &mut Recorder,
                            zeta_k: &[f64],
                            table: &mut envpg_ac::PolicyTable,
                            st: &envpg_ac::Stats|
     -> Result<(), LearnerError> {
        let p = rec.record(zeta_k, table, st);
        let every = cfg.checkpoint.as_ref().map_or(0, |cp| cp.every);
        if (every > 0 && learner.k().is_multiple_of(every)) || learner.k() == total {
            write_checkpoint(cfg, learner, rec)?;
        }
        if !progress(&p) {
            let _ = end.announce(d, true);
            write_checkpoint(cfg, learner, rec)?;
            return Err(LearnerError::Stopped(learner.k()));
        }
        Ok(())
    };
    // With a policy lag: the batch of iteration `learner.k()`, gathered but not yet learnt from.
    let mut pending: Option<Vec<Episode>> = None;
    loop {
        let k = learner.k();
        let Some(episodes) = pending.take() else {
            if k >= total {
                break;
            }
            // Nothing gathered ahead (the first iteration, lag 0, or a resumed run): sample
            // batch k with the weights it calls for, then learn from it or keep it.
            let b = learner.behaviour();
            end.publish_weights(k, b.alpha, b.zeta, b.actor)?;
            let Collected::Batch(episodes) = link.collect(k)? else {
                return Err(terminated(&learner, &rec));
            };
            if spec.config.lag == 0 {
                let (st, zeta_k, mut table) = update_now(&mut learner, episodes, &mut link.stats)?;
                after_update(&learner, &mut rec, &zeta_k, &mut table, &st)?;
            } else {
                pending = Some(episodes);
            }
            continue;
        };
        if k + 1 == total {
            // The last batch: nothing left to gather while learning from it.
            let (st, zeta_k, mut table) = update_now(&mut learner, episodes, &mut link.stats)?;
            after_update(&learner, &mut rec, &zeta_k, &mut table, &st)?;
            continue;
        }
        // Lag 1: batch k + 1 is sampled with θ_k, ζ_k, α_k — the weights the update of batch k
        // starts from, and so the learner's behaviour once it is done — while that update runs.
        let (mut table, zeta_k) = (learner.policy_table(), learner.zeta().to_vec());
        end.publish_weights(k + 1, learner.alpha(), &zeta_k, learner.actor().params())?;
        let ((st, seconds), next) = std::thread::scope(|scope| {
            let learner = &mut learner;
            let update = scope.spawn(move || {
                let started = Instant::now();
                (learner.update(&Batch { k, episodes }), started.elapsed().as_secs_f64())
            });
            let next = link.collect(k + 1);
            (update.join().expect("the update thread"), next)
        });
        link.stats.update_seconds += seconds;
        let st = st.map_err(TrainError::from)?;
        after_update(&learner, &mut rec, &zeta_k, &mut table, &st)?;
        match next? {
            Collected::Batch(episodes) => pending = Some(episodes),
            Collected::Terminated => return Err(terminated(&learner, &rec)),
        }
    }
    end.announce(d, true)?;
    let details = serde_json::json!({ "mode": "workers", "link": link.stats });
    let result = rec.finish(&learner, "envpg-ac", details);
    Ok((result, link.stats))
}

/// Updates on the learner's current batch with nothing to gather meanwhile; returns the
/// statistics with ζ_k and π_θk from before the update (what the history records).
fn update_now(
    learner: &mut envpg_ac::Learner,
    episodes: Vec<Episode>,
    stats: &mut LinkStats,
) -> Result<(envpg_ac::Stats, Vec<f64>, envpg_ac::PolicyTable<'static>), LearnerError> {
    let (table, zeta_k) = (learner.policy_table(), learner.zeta().to_vec());
    let (started, cpu) = (Instant::now(), process_cpu_seconds());
    let st = learner.update(&Batch { k: learner.k(), episodes }).map_err(TrainError::from)?;
    let seconds = started.elapsed().as_secs_f64();
    stats.update_seconds += seconds;
    stats.update_alone_seconds += seconds;
    stats.update_cpu_seconds += process_cpu_seconds() - cpu;
    Ok((st, zeta_k, table))
}

/// CPU seconds this process has used, all threads.
fn process_cpu_seconds() -> f64 {
    let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: `ts` is a valid, writable timespec; CLOCK_PROCESS_CPUTIME_ID exists on every
    // platform iceoryx2 runs on.
    let ok = unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut ts) } == 0;
    if ok { ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9 } else { 0.0 }
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
fn write_checkpoint(cfg: &LearnerConfig, learner: &Learner, rec: &Recorder) -> Result<(), LearnerError> {
    let Some(cp) = &cfg.checkpoint else { return Ok(()) };
    let spec = &cfg.spec;
    // The file is streamed (`Checkpoint::write_to`): at 10,000 users the state is ~60 MB, and a
    // write that copied it on the way was the learner's peak memory.
    let c = Checkpoint {
        protocol: PROTOCOL_VERSION,
        run_id: cfg.run_id.clone(),
        k: learner.k(),
        spec_json: serde_json::to_string(spec).map_err(|e| LearnerError::Checkpoint(e.to_string()))?,
        learner: encode_state(learner)?,
        history_json: serde_json::to_string(rec.history()).map_err(|e| LearnerError::Checkpoint(e.to_string()))?,
        transitions: rec.transitions(),
        capped: rec.capped(),
        seconds: rec.seconds(),
    };
    envpg_core::io::write_atomic_with(&cp.path, |w| c.write_to(w))
        .map_err(|e| LearnerError::Checkpoint(format!("{}: {e}", cp.path.display())))
}

/// A checkpoint from which the run `run_id` of `spec` trains again from iteration `k` at design
/// `zeta`, with the networks and optimisers of the finished run checkpointed in `from` (of the
/// same environment and settings, another seed): a warm start ([`Learner::rewind`]). Its
/// history, transitions and time are empty: the new run counts only its own.
pub fn warm_start(
    spec: &RunSpec,
    env: &LoadedEnv,
    run_id: &str,
    from: &Checkpoint,
    k: u64,
    zeta: Vec<f64>,
) -> Result<Checkpoint, LearnerError> {
    let (_, mut learner) = spec.start_on(env)?;
    restore_state(&mut learner, from)?;
    learner.rewind(k, zeta);
    let state = encode_state(&learner)?;
    Ok(Checkpoint {
        protocol: PROTOCOL_VERSION,
        run_id: run_id.to_owned(),
        k,
        spec_json: serde_json::to_string(spec).map_err(|e| LearnerError::Checkpoint(e.to_string()))?,
        learner: state,
        history_json: "[]".into(),
        transitions: 0,
        capped: 0,
        seconds: 0.0,
    })
}

/// The learner's state as a checkpoint carries it: serialised from the learner's own buffers
/// into one vector of its exact size (no copy of θ, φ, φ⁻ on the way).
fn encode_state(learner: &Learner) -> Result<Vec<u8>, LearnerError> {
    let failed = |e: postcard::Error| LearnerError::Checkpoint(e.to_string());
    let st = learner.state_ref();
    let len = postcard::experimental::serialized_size(&st).map_err(failed)?;
    postcard::to_extend(&st, Vec::with_capacity(len)).map_err(failed)
}

/// Restores `learner` to the state checkpointed in `c`.
fn restore_state(learner: &mut Learner, c: &Checkpoint) -> Result<(), LearnerError> {
    let st: LearnerState = postcard::from_bytes(&c.learner).map_err(|e| LearnerError::Checkpoint(e.to_string()))?;
    learner.restore(st).map_err(LearnerError::Checkpoint)
}

/// Reads the set of episode ids of an iteration (for tests and tools).
pub fn iteration_ids(spec: &RunSpec) -> BTreeSet<EpisodeId> {
    episode_ids(&spec.config).map(|(kind, e)| episode_id(kind, e)).collect()
}
