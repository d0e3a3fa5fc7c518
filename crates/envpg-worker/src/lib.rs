//! # envpg-worker
//!
//! The rollout worker: a thin process shell around the worker side of Algorithm 1
//! ([`envpg_ac::rollout::run_episode`]).
//!
//! [`run_worker`] joins a run through [`envpg_transport::WorkerEnd`], announces itself, then
//! blocks in a WaitSet. When the learner's weights for iteration k and a task naming this worker
//! have arrived, it builds π_θk(·|·, ζ_k) from the broadcast weights, runs the assigned episodes
//! (each from its own RNG stream, so the result does not depend on which worker runs it) and
//! publishes them, one message per episode and one wake-up per task. A heartbeat keeps the
//! learner informed; SIGINT/SIGTERM or the learner's end-of-run notice end the loop cleanly.
//!
//! [`CostlyEnv`] adds a fixed amount of real compute per step, to study scaling when the
//! environment, not the learner, dominates.
//!
//! Two worker threads and a learner on one run, over the process-local iceoryx2 service:
//!
//! ```
//! use std::sync::{Arc, atomic::{AtomicBool, Ordering}};
//! use std::time::Duration;
//! use envpg_ac::{AcConfig, trainer::{RunSpec, train}};
//! use envpg_learner::{LearnerConfig, run_learner};
//! use envpg_worker::{WorkerConfig, WorkerExit, run_worker};
//!
//! let registry = envpg_envs::registry();
//! let env = registry.load("flpo-n10m4", &[])?;
//! let config = AcConfig { iterations: 5, episodes: 8, explore_episodes: 4, hidden: vec![16], batch: 64,
//!     warmup: 2, eval_every: 5, polish_iterations: 0, ..AcConfig::default() };
//! let spec = RunSpec::new(&env, 3, config);
//! let (secs, run_over) = (Duration::from_secs, Arc::new(AtomicBool::new(false)));
//! let workers: Vec<_> = (0..2).map(|worker_id| {
//!     let cfg = WorkerConfig { run_id: "doc-workers".into(), spec: spec.clone(), env: env.clone(), worker_id,
//!         incarnation: 1, protocol: envpg_protocol::PROTOCOL_VERSION, join_timeout: secs(10),
//!         heartbeat: Duration::from_millis(100), emulator_cost_us: 0, run_over: Some(run_over.clone()) };
//!     std::thread::spawn(move || run_worker::<envpg_transport::local::Service>(&cfg))
//! }).collect();
//! let learner = LearnerConfig { run_id: "doc-workers".into(), spec: spec.clone(), env, max_workers: 2,
//!     worker_timeout: secs(10), checkpoint: None, resume: None, stall_timeout: secs(60), collect_only: false };
//! let (result, _) = run_learner::<envpg_transport::local::Service>(&learner, |_| true)?;
//! run_over.store(true, Ordering::Release); // a worker still joining now leaves instead of waiting
//! for w in workers { assert!(matches!(w.join().unwrap()?, WorkerExit::Finished | WorkerExit::RunOver)); }
//! // Whichever worker ran which episode, the result is bitwise the serial trainer's.
//! assert_eq!(result.zeta, train(&spec, &registry, |_| true)?.zeta);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use std::collections::BTreeMap;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use envpg_ac::features::Features;
use envpg_ac::nets::ActionSets;
use envpg_ac::rollout::{Episode, EpisodeKind, run_episode};
use envpg_ac::table::PolicyTable;
use envpg_ac::trainer::RunSpec;
use envpg_core::{EnvRng, LoadedEnv, ParamMdp, Streams, ZetaSpace};
use envpg_nn::{Mlp, MlpSpec};
use envpg_protocol::{EpisodeHeader, EpisodeId, MAX_ZETA, Step, hello_kind, run_id_bytes};
use envpg_transport::{TransportError, WorkerEnd};
use iceoryx2::prelude::*;
use iceoryx2::waitset::WaitSetRunResult;

/// How a worker is started.
#[derive(Debug, Clone)]
pub struct WorkerConfig {
    /// Run id (names the services).
    pub run_id: String,
    /// The run: instance, seed, settings.
    pub spec: RunSpec,
    /// The run's environment, built from `spec`'s instance.
    pub env: LoadedEnv,
    /// Worker slot.
    pub worker_id: u32,
    /// Distinguishes this process from an earlier one in the same slot.
    pub incarnation: u64,
    /// Protocol version to announce (normally [`envpg_protocol::PROTOCOL_VERSION`]).
    pub protocol: u32,
    /// How long to wait for the learner to appear.
    pub join_timeout: Duration,
    /// Heartbeat period.
    pub heartbeat: Duration,
    /// Extra compute per environment step, in microseconds (benchmarks).
    pub emulator_cost_us: u64,
    /// Set by an in-process run when its learner has returned: a worker thread still joining
    /// then leaves with [`WorkerExit::RunOver`] instead of waiting out `join_timeout`.
    pub run_over: Option<Arc<AtomicBool>>,
}

/// How a worker ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WorkerExit {
    /// The learner announced the end of the run.
    Finished,
    /// SIGINT or SIGTERM.
    Terminated,
    /// The run ended before this worker joined it: its learner had announced the end or was
    /// gone, or [`WorkerConfig::run_over`] was raised.
    RunOver,
}

/// Why a worker failed.
#[derive(Debug, thiserror::Error)]
pub enum WorkerError {
    /// The link failed.
    #[error(transparent)]
    Transport(#[from] TransportError),
    /// The run specification is unusable.
    #[error("run specification: {0}")]
    Spec(String),
    /// The learner's weights do not fit this run's networks.
    #[error("weights for iteration {k} have {got} parameters, the actor has {expected}")]
    Weights {
        /// Iteration.
        k: u64,
        /// Received.
        got: usize,
        /// Expected.
        expected: usize,
    },
    /// The WaitSet failed.
    #[error("waiting for events: {0}")]
    Wait(String),
}

/// A sampler that burns `cost` of real compute per step before delegating.
#[derive(Clone)]
pub struct CostlyEnv {
    /// The real sampler.
    pub inner: std::sync::Arc<dyn ParamMdp>,
    /// Busy time per step.
    pub cost: Duration,
}

impl ParamMdp for CostlyEnv {
    fn n_states(&self) -> usize {
        self.inner.n_states()
    }
    fn n_actions(&self) -> usize {
        self.inner.n_actions()
    }
    fn zeta_space(&self) -> &ZetaSpace {
        self.inner.zeta_space()
    }
    fn gamma(&self) -> f64 {
        self.inner.gamma()
    }
    fn valid_actions(&self, s: usize) -> &[usize] {
        self.inner.valid_actions(s)
    }
    fn is_terminal(&self, s: usize) -> bool {
        self.inner.is_terminal(s)
    }
    fn sample_initial(&self, rng: &mut EnvRng) -> usize {
        self.inner.sample_initial(rng)
    }
    fn sample_exploring_start(&self, rng: &mut EnvRng) -> usize {
        self.inner.sample_exploring_start(rng)
    }
    fn step(&self, s: usize, a: usize, zeta: &[f64], rng: &mut EnvRng) -> (usize, f64) {
        if !self.cost.is_zero() {
            let start = Instant::now();
            let mut x = 0u64;
            // Real work the optimiser cannot remove, until the budget is spent.
            while start.elapsed() < self.cost {
                for i in 0..64u64 {
                    x = x.wrapping_mul(6364136223846793005).wrapping_add(i);
                }
                std::hint::black_box(x);
            }
        }
        self.inner.step(s, a, zeta, rng)
    }
}

/// Writes an episode (ζ of dimension `d`) into `words` as the payload of an episode message:
/// [`envpg_protocol::step_words`]`(d)` words a step.
pub fn records(ep: &Episode, d: usize, words: &mut Vec<u32>) {
    let w = envpg_protocol::step_words(d);
    words.clear();
    words.resize(ep.len() * w, 0);
    for (t, out) in words.chunks_exact_mut(w).enumerate() {
        let step = Step { s: ep.s[t], a: ep.a[t], s2: ep.s2[t], cost: ep.cost[t] };
        envpg_protocol::write_step(out, step, &ep.zeta[t * d..(t + 1) * d]);
    }
}

/// The kind of an episode id.
pub fn kind_of(id: &EpisodeId) -> EpisodeKind {
    if id.kind == 0 { EpisodeKind::OnPolicy } else { EpisodeKind::Explore }
}

/// The rollout state needed to run episodes of one iteration.
struct Rollout {
    env: CostlyEnv,
    sets: ActionSets,
    features: Features,
    actor: Mlp<f32>,
    streams: Streams,
}

/// Runs a worker until the run ends or it is asked to stop.
pub fn run_worker<S: Service>(cfg: &WorkerConfig) -> Result<WorkerExit, WorkerError>
where
    iceoryx2::port::listener::Listener<S>: SynchronousMultiplexing,
{
    let spec = &cfg.spec;
    let net = cfg.env.sampler();
    if net.zeta_dim() > MAX_ZETA {
        return Err(WorkerError::Spec(format!(
            "ζ has {} coordinates; the distributed protocol carries at most {MAX_ZETA}",
            net.zeta_dim()
        )));
    }
    // The settings in absolute units, as the learner resolves them.
    let ac = &spec.config.resolve(net);
    let features = Features::with_state_onehot(net, cfg.env.env.feature_map(), ac.zeta_input, ac.state_onehot);
    let mlp_spec = MlpSpec { onehot: features.onehot(), dense: features.dense_dim(), hidden: ac.hidden.clone() };
    // The shape only: parameters come from the learner.
    let actor = Mlp::<f32>::new(mlp_spec, &mut Streams::new(0).stream(envpg_core::Purpose::Init, 0, 0), true);
    let mut ro = Rollout {
        sets: ActionSets::new(net),
        env: CostlyEnv { inner: cfg.env.shared_sampler(), cost: Duration::from_micros(cfg.emulator_cost_us) },
        features,
        actor,
        streams: Streams::new(spec.seed),
    };
    let d = ro.env.zeta_dim();

    let over = || cfg.run_over.as_ref().is_some_and(|f| f.load(Ordering::Acquire));
    // iceoryx2 keeps one termination flag per process and the first node or WaitSet to look
    // clears it: in an in-process run (`run_over` set) the learner thread must be the one to
    // see SIGINT, so that it checkpoints; its end of the run then stops the worker threads.
    let signals = if cfg.run_over.is_some() {
        SignalHandlingMode::Disabled
    } else {
        SignalHandlingMode::HandleTerminationRequests
    };
    let end = match WorkerEnd::<S>::open_while(
        &cfg.run_id,
        cfg.worker_id,
        cfg.protocol,
        cfg.join_timeout,
        &|| !over(),
        signals,
    ) {
        Err(TransportError::RunOver { .. }) => return Ok(WorkerExit::RunOver),
        Err(TransportError::Interrupted { .. }) => return Ok(WorkerExit::Terminated),
        // The learner tore its services down between our looks: the run is over, not broken.
        Err(_) if over() => return Ok(WorkerExit::RunOver),
        other => other?,
    };
    end.say(hello_kind::JOIN, cfg.worker_id, cfg.incarnation)?;
    let waitset = WaitSetBuilder::new()
        .signal_handling_mode(signals)
        .create::<S>()
        .map_err(|e| WorkerError::Wait(format!("{e:?}")))?;
    let _wake = waitset.attach_notification(end.listener()).map_err(|e| WorkerError::Wait(format!("{e:?}")))?;
    let _tick = waitset.attach_interval(cfg.heartbeat).map_err(|e| WorkerError::Wait(format!("{e:?}")))?;

    // The header of the weights now in `ro.actor`.
    let mut weights: Option<envpg_protocol::WeightsHeader> = None;
    let mut tasks: BTreeMap<u64, Vec<EpisodeId>> = BTreeMap::new();
    let mut seq = 0u64;
    let mut words = Vec::new();
    let mut last_beat = Instant::now();
    let run_id = run_id_bytes(&cfg.run_id);
    loop {
        let r = waitset
            .wait_and_process_once_with_timeout(|_| CallbackProgression::Continue, cfg.heartbeat)
            .map_err(|e| WorkerError::Wait(format!("{e:?}")))?;
        if matches!(r, WaitSetRunResult::TerminationRequest | WaitSetRunResult::Interrupt) {
            let _ = end.say(hello_kind::LEAVE, cfg.worker_id, cfg.incarnation);
            return Ok(WorkerExit::Terminated);
        }
        end.drain_wakeups();
        if end.run_finished()? {
            let _ = end.say(hello_kind::LEAVE, cfg.worker_id, cfg.incarnation);
            return Ok(WorkerExit::Finished);
        }
        // Weights are copied once, from shared memory straight into the actor.
        let mut bad = None;
        end.with_latest_weights(|h, params| {
            if weights.is_some_and(|w| h.k < w.k) {
                return;
            }
            if params.len() != ro.actor.n_params() {
                bad = Some(WorkerError::Weights { k: h.k, got: params.len(), expected: ro.actor.n_params() });
                return;
            }
            ro.actor.set_params(params);
            weights = Some(*h);
        })?;
        if let Some(e) = bad {
            return Err(e);
        }
        for (h, ids) in end.take_tasks()? {
            if h.worker_id == cfg.worker_id && h.incarnation == cfg.incarnation && h.run_id == run_id {
                tasks.entry(h.k).or_default().extend(ids);
            }
        }
        if let Some(h) = &weights {
            // Tasks for older iterations are stale; newer ones wait for their weights.
            tasks.retain(|&k, _| k >= h.k);
            if let Some(ids) = tasks.remove(&h.k) {
                let zeta = &h.zeta[..h.zeta_dim as usize];
                let mut table = PolicyTable::new(&ro.actor, &ro.features, &ro.sets, zeta);
                for id in &ids {
                    let ep = run_episode(
                        &ro.env,
                        &ro.sets,
                        &mut table,
                        zeta,
                        ac,
                        &ro.streams,
                        kind_of(id),
                        h.k,
                        id.index as u64,
                    );
                    let header = EpisodeHeader {
                        protocol: envpg_protocol::PROTOCOL_VERSION,
                        worker_id: cfg.worker_id,
                        run_id,
                        k: h.k,
                        episode: *id,
                        seq,
                        len: ep.len() as u32,
                        capped: u32::from(ep.capped),
                        zeta_dim: d as u32,
                        _pad: 0,
                    };
                    seq += 1;
                    records(&ep, d, &mut words);
                    end.publish_episode(header, &words)?;
                    if last_beat.elapsed() >= cfg.heartbeat {
                        end.say(hello_kind::HEARTBEAT, cfg.worker_id, cfg.incarnation)?;
                        last_beat = Instant::now();
                    }
                }
                end.notify_learner()?;
            }
        }
        if last_beat.elapsed() >= cfg.heartbeat {
            end.say(hello_kind::HEARTBEAT, cfg.worker_id, cfg.incarnation)?;
            last_beat = Instant::now();
        }
    }
}
