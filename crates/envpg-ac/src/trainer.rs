//! The serial wiring of Algorithm 1 — rollouts and learner in one process — plus the
//! [`Recorder`] that every driver (in-process or distributed) uses to keep the history and
//! write the result file.
//!
//! The recorder scores (ζ_k, greedy π_k) exactly every `eval_every` iterations with the model
//! (`envpg-model`), for the history only: nothing it computes flows back into training.

use std::time::Instant;

use envpg_core::policy::policy_rows;
use envpg_core::result::{HistoryRow, ResultFile, SCHEMA};
use envpg_core::{InstanceError, LoadedEnv, ModelMdp, ParamMdp, Registry, Streams};
use envpg_model::{Snapshot, evaluate};
use serde::{Deserialize, Serialize};

use crate::config::AcConfig;
use crate::learner::{Batch, Learner, LearnerError, Stats};
use crate::nets::ActionSets;
use crate::polish;
use crate::rollout::run_iteration;
use crate::table::PolicyTable;
use crate::zeta0::initial_design;

/// Everything that defines a run (and is stored in its result file).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunSpec {
    /// The instance in canonical form: its environment, fields and every parameter.
    pub instance: serde_json::Value,
    /// Seed.
    pub seed: u64,
    /// Algorithm settings.
    pub config: AcConfig,
}

/// Why a run failed.
#[derive(Debug, thiserror::Error)]
pub enum TrainError {
    /// Settings out of range.
    #[error(transparent)]
    Config(#[from] crate::config::ConfigError),
    /// The instance (or its environment) is unusable.
    #[error(transparent)]
    Instance(#[from] InstanceError),
    /// The initial design is unusable.
    #[error("initial design: {0}")]
    Zeta0(String),
    /// The learner refused a batch.
    #[error(transparent)]
    Learner(#[from] LearnerError),
    /// The run was stopped.
    #[error("stopped at iteration {0}")]
    Stopped(u64),
    /// A model-only step (the estimator study) on an environment without a model.
    #[error(transparent)]
    NoModel(#[from] envpg_core::NoModel),
}

impl RunSpec {
    /// The run of `config` with `seed` on `env`.
    pub fn new(env: &LoadedEnv, seed: u64, config: AcConfig) -> Self {
        Self { instance: env.instance.clone(), seed, config }
    }

    /// The environment of the run, built by `registry`.
    pub fn load(&self, registry: &Registry) -> Result<LoadedEnv, TrainError> {
        Ok(registry.from_value(&self.instance, "<run>")?)
    }

    /// Validates and builds the environment, the initial design and a fresh learner.
    pub fn start(&self, registry: &Registry) -> Result<(LoadedEnv, Vec<f64>, Learner), TrainError> {
        let env = self.load(registry)?;
        let (zeta0, learner) = self.start_on(&env)?;
        Ok((env, zeta0, learner))
    }

    /// As [`RunSpec::start`], on an environment already built from this spec's instance.
    pub fn start_on(&self, env: &LoadedEnv) -> Result<(Vec<f64>, Learner), TrainError> {
        self.config.validate()?;
        self.config.validate_for(env.env.feature_map().as_deref())?;
        let zeta0 = initial_design(env.sampler(), &self.config.zeta0, self.seed).map_err(TrainError::Zeta0)?;
        let config = self.config.resolve(env.sampler());
        let learner = Learner::new(env.shared_sampler(), env.env.feature_map(), config, self.seed, zeta0.clone());
        Ok((zeta0, learner))
    }
}

/// Progress of one iteration, for progress bars.
#[derive(Debug, Clone)]
pub struct Progress {
    /// Iteration just completed.
    pub k: u64,
    /// Total iterations.
    pub total: u64,
    /// α used.
    pub alpha: f64,
    /// The learner's J_H estimate.
    pub j_h_estimate: f64,
    /// Transitions per second so far.
    pub transitions_per_s: f64,
    /// Latest exact J (history), if any.
    pub j_exact: Option<f64>,
    /// The exact J computed at this iteration (every `eval_every`), if any.
    pub j_exact_now: Option<f64>,
    /// ‖ζ-gradient estimate‖ of this iteration (none where ζ is not learned).
    pub grad_norm: Option<f64>,
    /// The critic's TD loss of this iteration.
    pub critic_loss: f64,
    /// The actor's loss of this iteration.
    pub actor_loss: f64,
    /// The sampled J estimate of this iteration.
    pub j_estimate: f64,
    /// Wall-clock seconds of the run so far (all processes).
    pub seconds: f64,
}

/// Keeps the history of a run and writes its result file.
#[derive(Debug)]
pub struct Recorder {
    spec: RunSpec,
    env: LoadedEnv,
    sets: ActionSets,
    zeta0: Vec<f64>,
    history: Vec<HistoryRow>,
    transitions: u64,
    capped: u64,
    start: Instant,
    /// Seconds spent before this process (resumed runs).
    earlier: f64,
    last_exact: Option<f64>,
}

impl Recorder {
    /// A recorder for `spec` on `env` starting from `zeta0`.
    pub fn new(spec: &RunSpec, env: &LoadedEnv, zeta0: &[f64]) -> Self {
        Self {
            spec: spec.clone(),
            env: env.clone(),
            sets: ActionSets::new(env.sampler()),
            zeta0: zeta0.to_vec(),
            history: Vec::new(),
            transitions: 0,
            capped: 0,
            start: Instant::now(),
            earlier: 0.0,
            last_exact: None,
        }
    }

    /// Adds time spent before a resume.
    pub fn add_seconds(&mut self, s: f64) {
        self.earlier += s;
    }

    /// Wall-clock seconds of the run so far (all processes).
    pub fn seconds(&self) -> f64 {
        self.earlier + self.start.elapsed().as_secs_f64()
    }

    /// Resumes the history of a checkpointed run.
    pub fn resume(&mut self, history: Vec<HistoryRow>, transitions: u64, capped: u64) {
        self.history = history;
        self.transitions = transitions;
        self.capped = capped;
        self.last_exact = self.history.iter().rev().find_map(|h| h.j_exact);
    }

    /// The history so far.
    pub fn history(&self) -> &[HistoryRow] {
        &self.history
    }
    /// Transitions so far.
    pub fn transitions(&self) -> u64 {
        self.transitions
    }
    /// Capped episodes so far.
    pub fn capped(&self) -> u64 {
        self.capped
    }

    /// Records iteration `stats.k`, run at `zeta_k` with policy `table`; with a model, the
    /// exact J of (ζ_k, greedy π_k) every `eval_every` iterations, for the record only.
    pub fn record(&mut self, zeta_k: &[f64], table: &mut PolicyTable, stats: &Stats) -> Progress {
        self.transitions += stats.transitions as u64;
        self.capped += stats.capped as u64;
        let cfg = &self.spec.config;
        let last = stats.k + 1 == cfg.iterations as u64;
        let model = self.env.env.model();
        let j_exact = if let Some(model) = model.filter(|_| stats.k.is_multiple_of(cfg.eval_every as u64) || last) {
            let j = exact_greedy_j(model, &self.sets, zeta_k, table).ok();
            self.last_exact = j.or(self.last_exact);
            j
        } else {
            None
        };
        self.history.push(HistoryRow {
            k: stats.k,
            alpha: stats.alpha,
            j_h_estimate: Some(stats.j_h_estimate),
            grad_norm: stats.grad_norm,
            zeta: zeta_k.to_vec(),
            j_exact,
            stats: Some(serde_json::json!({
                "J_estimate": stats.j_estimate,
                "critic_loss": stats.critic_loss,
                "actor_loss": stats.actor_loss,
                "mean_len": stats.mean_len,
                "capped": stats.capped,
                "transitions": stats.transitions,
                "relocated": stats.relocated,
                "looping": stats.looping,
            })),
        });
        Progress {
            k: stats.k,
            total: cfg.iterations as u64,
            alpha: stats.alpha,
            j_h_estimate: stats.j_h_estimate,
            transitions_per_s: self.transitions as f64 / self.start.elapsed().as_secs_f64().max(1e-9),
            j_exact: self.last_exact,
            j_exact_now: j_exact,
            grad_norm: stats.grad_norm,
            critic_loss: stats.critic_loss,
            actor_loss: stats.actor_loss,
            j_estimate: stats.j_estimate,
            seconds: self.seconds(),
        }
    }

    /// The result file of the finished run: final ζ, greedy policy with its exact J, the soft
    /// policy with its exact J_H at the final α (exact scores need the environment's model;
    /// without one `J` is null and `j_error` says why).
    ///
    /// Both policies are the actor's at the reported ζ of Algorithm 1. With
    /// `polish_iterations > 0` the design is then polished for the greedy one
    /// ([`crate::polish`]), whose policy the polish may improve (`polish_policy_rounds`): the
    /// greedy policy reported is the one the design was polished for, and both policies are
    /// scored at the polished ζ; `details.polish` keeps the design before the polish with its
    /// greedy policy and their exact J (`J_before`): Algorithm 1 alone.
    pub fn finish(&self, learner: &Learner, method: &str, details: serde_json::Value) -> ResultFile {
        self.finish_with(learner, method, details, true)
    }

    /// [`Recorder::finish`] without the ζ polish, whatever the settings (benchmarks of rollouts
    /// and transport, which never train).
    pub fn finish_unpolished(&self, learner: &Learner, method: &str, details: serde_json::Value) -> ResultFile {
        self.finish_with(learner, method, details, false)
    }

    fn finish_with(&self, learner: &Learner, method: &str, details: serde_json::Value, polish: bool) -> ResultFile {
        let env = self.env.sampler();
        let model = self.env.env.model();
        let before = learner.reported_zeta();
        let mut table = PolicyTable::new(learner.actor(), learner.features(), learner.action_sets(), &before);
        let started = Instant::now();
        let (zeta, greedy, polish) = if polish && learner.config().polish_iterations > 0 {
            let settings = learner.config().polish();
            let streams = Streams::new(self.spec.seed);
            // Each start begins with the actor's greedy policy at that design.
            let starts: Vec<(Vec<f64>, Vec<usize>)> =
                polish::candidate_starts(&before, &settings, &streams, env.zeta_space())
                    .into_iter()
                    .map(|z| {
                        let actions = PolicyTable::new(learner.actor(), learner.features(), learner.action_sets(), &z)
                            .greedy_actions();
                        (z, actions)
                    })
                    .collect();
            let (z, action, report) = polish::polish_candidates(env, &starts, &settings, &streams);
            let mut report = serde_json::to_value(&report).expect("report serializes");
            let greedy_before = table.greedy();
            let (j_before, err_before) = exact_j(model, &before, &greedy_before, 0.0, self.env.name);
            if let Some(obj) = report.as_object_mut() {
                obj.insert("J_before".into(), j_before.into());
                if let Some(e) = err_before {
                    obj.insert("j_error_before".into(), e.into());
                }
                obj.insert(
                    "policy_before".into(),
                    serde_json::to_value(policy_rows(env, &greedy_before)).expect("rows"),
                );
            }
            (z, self.sets.one_hot(&action), Some(report))
        } else {
            (before, table.greedy(), None)
        };
        let polish_seconds = started.elapsed().as_secs_f64();
        let (j, j_error) = exact_j(model, &zeta, &greedy, 0.0, self.env.name);
        let alpha = learner.alpha();
        let soft = table.full().to_vec();
        let (j_h, _) = exact_j(model, &zeta, &soft, alpha, self.env.name);
        // The run's clock has run through the polish already.
        let seconds = self.seconds();
        let mut details = details;
        if let Some(obj) = details.as_object_mut() {
            if let Some(mut report) = polish {
                report["seconds"] = polish_seconds.into();
                obj.insert("polish".into(), report);
            }
            obj.insert("transitions".into(), self.transitions.into());
            obj.insert("capped_episodes".into(), self.capped.into());
            obj.insert("transitions_per_s".into(), (self.transitions as f64 / seconds.max(1e-9)).into());
            obj.insert("iterations".into(), learner.k().into());
        }
        ResultFile {
            schema: SCHEMA.into(),
            method: method.into(),
            env: self.env.name.into(),
            instance: self.env.instance.clone(),
            seed: self.spec.seed,
            zeta,
            zeta0: self.zeta0.clone(),
            policy: policy_rows(env, &greedy),
            j,
            j_error,
            j_h,
            alpha_final: Some(alpha),
            policy_soft: Some(policy_rows(env, &soft)),
            seconds: Some(seconds),
            config: Some(serde_json::to_value(&self.spec.config).expect("config serializes")),
            details: Some(details),
            history: Some(self.history.clone()),
        }
    }
}

/// Exact J (α = 0) or J_H of the per-pair policy `pi` at `zeta`, or why there is none.
fn exact_j(
    model: Option<&dyn ModelMdp>,
    zeta: &[f64],
    pi: &[f64],
    alpha: f64,
    env: &str,
) -> (Option<f64>, Option<String>) {
    let Some(model) = model else {
        return (None, Some(envpg_core::NoModel(env.to_owned()).to_string()));
    };
    match evaluate(&Snapshot::build(model, zeta), pi, alpha) {
        Ok(v) => (Some(v.j), None),
        Err(e) => (None, Some(e.to_string())),
    }
}

/// Exact J of (ζ, greedy of `table`), for reporting.
pub fn exact_greedy_j<M: ModelMdp + ?Sized>(
    model: &M,
    sets: &ActionSets,
    zeta: &[f64],
    table: &mut PolicyTable,
) -> Result<f64, envpg_model::ModelError> {
    let snap = Snapshot::build(model, zeta);
    debug_assert_eq!(snap.n_pairs(), sets.n_pairs());
    Ok(evaluate(&snap, &table.greedy(), 0.0)?.j)
}

/// Trains `learner` serially for `iterations` more iterations on `env` (each: the policy table
/// of [`Learner::behaviour`] — (θ_k, ζ_k), or with a policy lag (θ_{k−1}, ζ_{k−1}) — the
/// iteration's episodes, one update), without recording anything.
pub fn advance<E: ParamMdp + ?Sized>(
    env: &E,
    learner: &mut Learner,
    config: &AcConfig,
    streams: &Streams,
    iterations: usize,
) -> Result<(), LearnerError> {
    let sets = learner.action_sets().clone();
    for _ in 0..iterations {
        let k = learner.k();
        let mut table = learner.behaviour_table();
        let zeta = learner.behaviour().zeta.to_vec();
        let episodes = run_iteration(env, &sets, &mut table, &zeta, config, streams, k);
        learner.update(&Batch { k, episodes })?;
    }
    Ok(())
}

/// Runs Algorithm 1 in this process on the environment `registry` builds from the spec's
/// instance: for each k, the policy table at (θ_k, ζ_k), all episodes of the iteration in index
/// order, one learner update. `progress` sees every iteration and may stop the run by
/// returning `false`.
pub fn train(
    spec: &RunSpec,
    registry: &Registry,
    mut progress: impl FnMut(&Progress) -> bool,
) -> Result<ResultFile, TrainError> {
    let (env, zeta0, mut learner) = spec.start(registry)?;
    let mut rec = Recorder::new(spec, &env, &zeta0);
    let streams = Streams::new(spec.seed);
    let sets = learner.action_sets().clone();
    while (learner.k() as usize) < spec.config.iterations {
        let k = learner.k();
        let mut table = learner.policy_table();
        let zeta_k = learner.zeta().to_vec();
        let episodes = if learner.config().lag == 0 {
            run_iteration(env.sampler(), &sets, &mut table, &zeta_k, learner.config(), &streams, k)
        } else {
            let (mut behaviour, zeta) = (learner.behaviour_table(), learner.behaviour().zeta.to_vec());
            run_iteration(env.sampler(), &sets, &mut behaviour, &zeta, learner.config(), &streams, k)
        };
        let stats = learner.update(&Batch { k, episodes })?;
        let p = rec.record(&zeta_k, &mut table, &stats);
        if !progress(&p) {
            return Err(TrainError::Stopped(k));
        }
    }
    Ok(rec.finish(&learner, "envpg-ac", serde_json::json!({ "mode": "in-process" })))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_results_seconds_count_the_polish_once() {
        let registry = envpg_envs::registry();
        let env = registry.load("uav271", &[]).unwrap();
        let mut config = AcConfig::bundled("uav").unwrap();
        config.iterations = 2;
        config.eval_every = 1000;
        config.polish_iterations = 5;
        config.polish_episodes = 256;
        let spec = RunSpec::new(&env, 1, config);
        let started = Instant::now();
        let result = train(&spec, &registry, |_| true).unwrap();
        let wall = started.elapsed().as_secs_f64();
        let polish = result.details.as_ref().unwrap()["polish"]["seconds"].as_f64().unwrap();
        let seconds = result.seconds.unwrap();
        assert!(polish > 0.0 && seconds <= wall, "the result says {seconds} s (polish {polish} s) of a {wall} s run");
    }
}
