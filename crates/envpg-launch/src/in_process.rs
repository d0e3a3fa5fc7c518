//! The in-process fallback: the same learner and worker shells as threads of this process,
//! linked by iceoryx2's process-local service (no shared memory needed).

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use anyhow::Result;
use envpg_ac::trainer::Progress;
use envpg_core::{LoadedEnv, ResultFile};
use envpg_learner::{CheckpointPolicy, LearnerConfig, LinkStats, run_learner};
use envpg_protocol::{Checkpoint, PROTOCOL_VERSION};
use envpg_transport::local;
use envpg_worker::{WorkerConfig, run_worker};

use crate::run_dir::RunFile;

/// Runs learner and `run.workers` workers (at least one) as threads.
pub fn run(
    run: &RunFile,
    env: &LoadedEnv,
    checkpoint: Option<CheckpointPolicy>,
    resume: Option<Checkpoint>,
    progress: impl FnMut(&Progress) -> bool,
) -> Result<(ResultFile, LinkStats)> {
    let workers = run.workers.max(1);
    let lcfg = LearnerConfig {
        run_id: run.run_id.clone(),
        spec: run.spec.clone(),
        env: env.clone(),
        max_workers: workers + 2,
        worker_timeout: Duration::from_millis(run.worker_timeout_ms),
        checkpoint,
        resume,
        stall_timeout: Duration::from_secs(60),
        collect_only: false,
    };
    // Raised when the learner returns, so that a worker thread still joining (the others did
    // all the work) leaves at once, and errors of the torn-down link are not reported.
    let over = Arc::new(AtomicBool::new(false));
    std::thread::scope(|scope| {
        for i in 0..workers {
            let wcfg = WorkerConfig {
                run_id: run.run_id.clone(),
                spec: run.spec.clone(),
                env: env.clone(),
                worker_id: i as u32,
                incarnation: 1,
                protocol: PROTOCOL_VERSION,
                join_timeout: Duration::from_secs(30),
                heartbeat: Duration::from_millis((run.worker_timeout_ms / 5).clamp(10, 500)),
                emulator_cost_us: run.emulator_cost_us,
                run_over: Some(over.clone()),
            };
            let over = over.clone();
            scope.spawn(move || {
                if let Err(e) = run_worker::<local::Service>(&wcfg)
                    && !over.load(Ordering::Acquire)
                {
                    eprintln!("worker {i}: {e}");
                }
            });
        }
        let result = run_learner::<local::Service>(&lcfg, progress).map_err(anyhow::Error::from);
        over.store(true, Ordering::Release);
        result
    })
}
