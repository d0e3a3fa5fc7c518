//! `envpg-launch --bench`: rollout and transport throughput, side by side in one run.
//!
//! Every measurement moves the same episodes (collect-only: the learner gathers each
//! iteration's episodes but never updates, so the policy and ζ stay fixed):
//!
//! 1. `raw`: emulator + actor in one thread, no transport — the limit of one core;
//! 2. `in-process`: learner and one worker thread over iceoryx2's process-local service;
//! 3. `ipc` with 1, 2, … worker processes over shared memory;
//!
//! then whole training runs (`train`: the learner updates, the polish is skipped) with 1, 2, …
//! worker processes, with policy lag 0 and 1 side by side, each with the learner's share of the
//! run (its seconds in `Learner::update` over the run's); and last the latency of broadcasting
//! the actor's weights to a subscriber blocked in a WaitSet. The one-worker measurements fit a
//! [`Model`] of training throughput, whose predictions are printed beside what was measured and
//! for up to 64 workers.

use std::path::Path;
use std::time::{Duration, Instant};

use anyhow::Result;
use envpg_ac::nets::ActionSets;
use envpg_ac::rollout::run_iteration;
use envpg_ac::trainer::RunSpec;
use envpg_core::{LoadedEnv, Streams};
use envpg_learner::{LearnerConfig, run_learner};
use envpg_protocol::{Checkpoint, PROTOCOL_VERSION};
use envpg_transport::{LearnerEnd, LinkSizes, WorkerEnd, ipc, local};
use envpg_worker::{CostlyEnv, WorkerConfig, run_worker};
use iceoryx2::prelude::*;
use serde::Serialize;

use crate::run_dir::{RunFile, new_run_id};
use crate::throughput_model::Model;

/// One throughput measurement.
#[derive(Debug, Clone, Serialize)]
pub struct Throughput {
    /// `raw`, `in-process`, `ipc` (collect-only) or `train`.
    pub mode: String,
    /// Policy lag of a `train` measurement.
    pub lag: Option<usize>,
    /// Of a `train` measurement: the learner's seconds in `Learner::update` over the run's.
    pub learner_share: Option<f64>,
    /// Of a `train` measurement: the cores the update keeps busy when it runs alone (its
    /// process's CPU seconds over its wall seconds).
    pub update_cores: Option<f64>,
    /// Worker threads or processes.
    pub workers: usize,
    /// Transitions moved.
    pub transitions: u64,
    /// Wall-clock seconds.
    pub seconds: f64,
    /// Transitions per second.
    pub per_second: f64,
}

impl Throughput {
    /// `transitions` moved in `seconds` by `workers` in `mode` (none of a training run's extras).
    fn measured(mode: &str, workers: usize, transitions: u64, seconds: f64) -> Self {
        Self {
            mode: mode.into(),
            lag: None,
            learner_share: None,
            update_cores: None,
            workers,
            transitions,
            seconds,
            per_second: transitions as f64 / seconds,
        }
    }
}

/// The whole benchmark.
#[derive(Debug, Serialize)]
pub struct Report {
    /// Extra compute per step (µs).
    pub emulator_cost_us: u64,
    /// Iterations per measurement.
    pub iterations: usize,
    /// Rounds per mode (the median is reported).
    pub repeats: usize,
    /// Episodes per iteration.
    pub episodes_per_iteration: usize,
    /// Measurements.
    pub throughput: Vec<Throughput>,
    /// Actor parameters per broadcast.
    pub broadcast_floats: usize,
    /// Broadcast latency percentiles (µs): p50, p90, p99.
    pub broadcast_latency_us: [f64; 3],
    /// The throughput model fitted to the one-worker measurements (raw, collect-only, lag-0
    /// training), if they were taken.
    pub model: Option<Model>,
    /// Its predictions: for the measured worker counts on this machine's cores (with the
    /// gathering time their collect-only runs measured), and for 1–64 workers with a core for
    /// every process (gathering split evenly).
    pub predictions: Vec<Prediction>,
}

/// Training throughput predicted by the [`Model`].
#[derive(Debug, Serialize)]
pub struct Prediction {
    /// Worker processes.
    pub workers: usize,
    /// Policy lag.
    pub lag: usize,
    /// Cores.
    pub cores: usize,
    /// Predicted transitions/s.
    pub per_second: f64,
    /// Measured transitions/s, where this run measured the same (workers, lag, cores).
    pub measured: Option<f64>,
}

/// Fits the model to a report's one-worker rows.
fn fit(throughput: &[Throughput], iterations: usize) -> Option<Model> {
    let find = |mode: &str, workers: usize, lag: Option<usize>| {
        throughput.iter().find(|t| t.mode == mode && t.workers == workers && t.lag == lag)
    };
    let (raw, collect, train) = (find("raw", 0, None)?, find("ipc", 1, None)?, find("train", 1, Some(0))?);
    let n = iterations.max(1) as f64;
    let update = train.learner_share? * train.seconds / n;
    let per_iteration = train.transitions as f64 / n;
    Some(Model::fit(raw.per_second, collect.per_second, train.per_second, per_iteration, update, train.update_cores?))
}

fn learner_cfg(run_id: &str, env: &LoadedEnv, spec: &RunSpec, workers: usize, collect_only: bool) -> LearnerConfig {
    LearnerConfig {
        run_id: run_id.to_owned(),
        spec: spec.clone(),
        env: env.clone(),
        max_workers: workers + 2,
        worker_timeout: Duration::from_secs(5),
        checkpoint: None,
        resume: None::<Checkpoint>,
        stall_timeout: Duration::from_secs(60),
        collect_only,
    }
}

fn raw(loaded: &LoadedEnv, spec: &RunSpec, cost_us: u64) -> Result<Throughput> {
    let (zeta0, learner) = spec.start_on(loaded)?;
    let env = CostlyEnv { inner: loaded.shared_sampler(), cost: Duration::from_micros(cost_us) };
    let sets = ActionSets::new(&env);
    let streams = Streams::new(spec.seed);
    let start = Instant::now();
    let mut transitions = 0u64;
    for k in 0..spec.config.iterations as u64 {
        let mut table = learner.policy_table();
        for ep in run_iteration(&env, &sets, &mut table, &zeta0, learner.config(), &streams, k) {
            transitions += ep.len() as u64;
        }
    }
    let seconds = start.elapsed().as_secs_f64();
    Ok(Throughput::measured("raw", 0, transitions, seconds))
}

fn in_process(env: &LoadedEnv, spec: &RunSpec, cost_us: u64) -> Result<Throughput> {
    let run_id = new_run_id();
    let lcfg = learner_cfg(&run_id, env, spec, 1, true);
    let start = Instant::now();
    let stats = std::thread::scope(|scope| {
        let wcfg = worker_cfg(&run_id, env, spec, 0, cost_us);
        scope.spawn(move || run_worker::<local::Service>(&wcfg));
        run_learner::<local::Service>(&lcfg, |_| true).map(|(_, s)| s)
    })?;
    let seconds = start.elapsed().as_secs_f64();
    Ok(Throughput::measured("in-process", 1, stats.transitions, seconds))
}

fn worker_cfg(run_id: &str, env: &LoadedEnv, spec: &RunSpec, id: u32, cost_us: u64) -> WorkerConfig {
    WorkerConfig {
        run_id: run_id.to_owned(),
        spec: spec.clone(),
        env: env.clone(),
        worker_id: id,
        incarnation: 1,
        protocol: PROTOCOL_VERSION,
        join_timeout: Duration::from_secs(30),
        heartbeat: Duration::from_millis(200),
        emulator_cost_us: cost_us,
        run_over: None,
    }
}

/// `workers` worker processes over shared memory: collect-only, or with `train = Some(lag)` a
/// training run with that policy lag (the polish skipped).
fn ipc_workers(
    env: &LoadedEnv,
    spec: &RunSpec,
    cost_us: u64,
    workers: usize,
    dir: &Path,
    train: Option<usize>,
) -> Result<Throughput> {
    let run_id = new_run_id();
    let mut spec = spec.clone();
    if let Some(lag) = train {
        spec.config.lag = lag;
        spec.config.polish_iterations = 0;
    }
    let run = RunFile {
        run_id: run_id.clone(),
        spec: spec.clone(),
        out: dir.join("unused.json"),
        workers,
        checkpoint_every: 0,
        emulator_cost_us: cost_us,
        worker_timeout_ms: 5000,
        stall_timeout_s: 60,
        listen: None,
        tensorboard: None,
        passes: 1,
        pass_start: Default::default(),
    };
    run.save(dir)?;
    let mut children: Vec<std::process::Child> = (0..workers)
        .map(|i| {
            crate::program::command(&[
                "worker".into(),
                "--run-dir".into(),
                dir.display().to_string(),
                "--worker-id".into(),
                i.to_string(),
            ])?
            .spawn()
        })
        .collect::<std::io::Result<_>>()?;
    let start = Instant::now();
    let res = run_learner::<ipc::Service>(&learner_cfg(&run_id, env, &spec, workers, train.is_none()), |_| true);
    let seconds = start.elapsed().as_secs_f64();
    for c in &mut children {
        let _ = c.wait();
    }
    let stats = res?.1;
    let mut t =
        Throughput::measured(if train.is_some() { "train" } else { "ipc" }, workers, stats.transitions, seconds);
    if train.is_some() {
        t.lag = train;
        t.learner_share = Some(stats.update_seconds / seconds);
        t.update_cores =
            (stats.update_alone_seconds > 0.0).then(|| stats.update_cpu_seconds / stats.update_alone_seconds);
    }
    Ok(t)
}

/// Latency of one weights broadcast of `n` floats from publish to a WaitSet wake-up and
/// receipt in another thread (shared memory), over `rounds` rounds.
fn broadcast_latency(n: usize, rounds: usize) -> Result<[f64; 3]> {
    let run_id = new_run_id();
    let sizes = LinkSizes { max_workers: 1, n_params: n, episode_cap: 1, episodes_per_iteration: 1 };
    let learner = LearnerEnd::<ipc::Service>::create(&run_id, sizes)?;
    learner.announce(1, false)?;
    let params = vec![0.5f32; n];
    let (tx, rx) = std::sync::mpsc::channel::<(u64, Instant)>();
    let mut lat = Vec::with_capacity(rounds);
    std::thread::scope(|scope| -> Result<()> {
        let rid = run_id.clone();
        let h = scope.spawn(move || -> Result<()> {
            let w = WorkerEnd::<ipc::Service>::open(&rid, 0, PROTOCOL_VERSION, Duration::from_secs(10))?;
            w.say(envpg_protocol::hello_kind::JOIN, 0, 1)?;
            let ws = WaitSetBuilder::new().create::<ipc::Service>().map_err(|e| anyhow::anyhow!("{e:?}"))?;
            let _g = ws.attach_notification(w.listener()).map_err(|e| anyhow::anyhow!("{e:?}"))?;
            let mut seen = 0;
            while seen < rounds {
                ws.wait_and_process_once_with_timeout(|_| CallbackProgression::Continue, Duration::from_millis(100))
                    .map_err(|e| anyhow::anyhow!("{e:?}"))?;
                w.drain_wakeups();
                if let Some((h, p)) = w.latest_weights()? {
                    let _ = tx.send((h.k, Instant::now()));
                    std::hint::black_box(p);
                    seen += 1;
                }
            }
            Ok(())
        });
        // Wait for the subscriber to join before timing anything.
        let start = Instant::now();
        while learner.receive_hellos()?.is_empty() {
            learner.refresh();
            anyhow::ensure!(start.elapsed() < Duration::from_secs(10), "latency probe did not join");
            std::thread::sleep(Duration::from_millis(1));
        }
        for k in 0..rounds as u64 {
            let sent = Instant::now();
            learner.publish_weights(k, 0.0, &[0.0], &params)?;
            learner.notify_workers()?;
            let (got_k, at) = rx.recv_timeout(Duration::from_secs(10))?;
            anyhow::ensure!(got_k == k, "latency probe saw iteration {got_k}, expected {k}");
            lat.push(at.duration_since(sent).as_secs_f64() * 1e6);
        }
        h.join().map_err(|_| anyhow::anyhow!("latency probe panicked"))??;
        Ok(())
    })?;
    lat.sort_by(f64::total_cmp);
    let q = |p: f64| lat[((lat.len() as f64 - 1.0) * p).round() as usize];
    Ok([q(0.5), q(0.9), q(0.99)])
}

/// Runs every measurement of the benchmark `repeats` times, interleaved so that slow phases of a
/// shared machine hit every mode alike, and keeps each mode's median.
pub fn run(
    env: &LoadedEnv,
    spec: &RunSpec,
    cost_us: u64,
    worker_counts: &[usize],
    repeats: usize,
    dir: &Path,
) -> Result<Report> {
    let episodes = spec.config.episodes + spec.config.explore_episodes;
    let mut rounds: Vec<Vec<Throughput>> = Vec::new();
    for _ in 0..repeats.max(1) {
        let mut round = vec![raw(env, spec, cost_us)?, in_process(env, spec, cost_us)?];
        for &w in worker_counts {
            round.push(ipc_workers(env, spec, cost_us, w, dir, None)?);
        }
        for &w in worker_counts {
            for lag in [0, 1] {
                round.push(ipc_workers(env, spec, cost_us, w, dir, Some(lag))?);
            }
        }
        rounds.push(round);
    }
    let throughput: Vec<Throughput> = (0..rounds[0].len())
        .map(|i| {
            let mut all: Vec<&Throughput> = rounds.iter().map(|r| &r[i]).collect();
            all.sort_by(|a, b| a.per_second.total_cmp(&b.per_second));
            all[all.len() / 2].clone()
        })
        .collect();
    let n = spec.start_on(env)?.1.actor().n_params();
    let model = fit(&throughput, spec.config.iterations);
    let cores = std::thread::available_parallelism().map_or(1, |c| c.get());
    let mut predictions = Vec::new();
    if let Some(m) = &model {
        let here = worker_counts.iter().map(|&w| (w, cores, true));
        let counts = here.chain([1, 2, 4, 8, 16, 32, 64].map(|w| (w, w + 1, false)));
        for (workers, cores, measured_here) in counts {
            for lag in [0, 1] {
                let row = |mode: &str, lag: Option<usize>| {
                    throughput.iter().find(|t| measured_here && t.mode == mode && t.workers == workers && t.lag == lag)
                };
                let measured = row("train", Some(lag)).map(|t| t.per_second);
                // Where this machine gathered with these workers, that time (uneven shares
                // included) replaces the even split.
                let gather = row("ipc", None).map_or(m.gather_seconds(workers), |t| m.transitions / t.per_second);
                let per_second = m.transitions / m.iteration_seconds_with(gather, lag, cores);
                predictions.push(Prediction { workers, lag, cores, per_second, measured });
            }
        }
    }
    Ok(Report {
        emulator_cost_us: cost_us,
        iterations: spec.config.iterations,
        repeats: repeats.max(1),
        episodes_per_iteration: episodes,
        throughput,
        broadcast_floats: n,
        broadcast_latency_us: broadcast_latency(n, 300)?,
        model,
        predictions,
    })
}

/// Prints the report as a table with ratios.
pub fn print(r: &Report) {
    println!(
        "throughput ({} iterations × {} episodes, emulator cost {} µs/step, collect-only, median of {} rounds)",
        r.iterations, r.episodes_per_iteration, r.emulator_cost_us, r.repeats
    );
    let raw = r.throughput.iter().find(|t| t.mode == "raw").map_or(1.0, |t| t.per_second);
    let inproc = r.throughput.iter().find(|t| t.mode == "in-process").map_or(1.0, |t| t.per_second);
    let one = r.throughput.iter().find(|t| t.mode == "ipc" && t.workers == 1).map_or(1.0, |t| t.per_second);
    println!(
        "{:<11} {:>7} {:>14} {:>8} {:>12} {:>11}",
        "mode", "workers", "transitions/s", "vs raw", "vs in-proc", "scaling"
    );
    for t in r.throughput.iter().filter(|t| t.mode != "train") {
        let scaling = if t.mode == "ipc" {
            format!("{:.0}%", 100.0 * t.per_second / (one * t.workers as f64))
        } else {
            "-".into()
        };
        println!(
            "{:<11} {:>7} {:>14.0} {:>7.0}% {:>11.0}% {:>11}",
            t.mode,
            t.workers,
            t.per_second,
            100.0 * t.per_second / raw,
            100.0 * t.per_second / inproc,
            scaling
        );
    }
    let train: Vec<&Throughput> = r.throughput.iter().filter(|t| t.mode == "train").collect();
    if !train.is_empty() {
        println!(
            "training (worker processes, the learner updating, no polish; scaling: against twice the same lag's 1-worker figure)"
        );
        println!(
            "{:>7} {:>4} {:>14} {:>14} {:>10} {:>11}",
            "workers", "lag", "transitions/s", "learner share", "scaling", "vs lag 0"
        );
        let find =
            |w: usize, lag: usize| train.iter().find(|t| t.workers == w && t.lag == Some(lag)).map(|t| t.per_second);
        for t in &train {
            let lag = t.lag.unwrap_or(0);
            let pct = |x: Option<f64>| x.map_or("-".to_string(), |x| format!("{:.0}%", 100.0 * x));
            println!(
                "{:>7} {:>4} {:>14.0} {:>14} {:>10} {:>11}",
                t.workers,
                lag,
                t.per_second,
                pct(t.learner_share),
                pct(find(1, lag).map(|one| t.per_second / (one * t.workers as f64))),
                pct(find(t.workers, 0).map(|l0| t.per_second / l0)),
            );
        }
    }
    if let Some(m) = &r.model {
        println!(
            "model (per iteration: {:.0} transitions, sampling {:.2} µs and transport {:.2} µs a transition, update {:.2} ms on {:.2} cores, rest {:.2} ms)",
            m.transitions,
            m.sample * 1e6,
            m.transport * 1e6,
            m.update * 1e3,
            m.update_cores,
            m.rest * 1e3
        );
        println!("{:>7} {:>4} {:>6} {:>18} {:>10}", "workers", "lag", "cores", "predicted tr/s", "measured");
        for p in &r.predictions {
            let measured = p.measured.map_or("-".to_string(), |x| format!("{x:.0}"));
            println!("{:>7} {:>4} {:>6} {:>18.0} {:>10}", p.workers, p.lag, p.cores, p.per_second, measured);
        }
    }
    println!(
        "weights broadcast ({} floats, {} KiB): p50 {:.0} µs, p90 {:.0} µs, p99 {:.0} µs",
        r.broadcast_floats,
        r.broadcast_floats * 4 / 1024,
        r.broadcast_latency_us[0],
        r.broadcast_latency_us[1],
        r.broadcast_latency_us[2]
    );
}
