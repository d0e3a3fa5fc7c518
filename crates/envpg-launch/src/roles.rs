//! The learner and worker processes: read the run directory, run the shell, report.

use std::path::Path;
use std::time::Duration;

use anyhow::{Result, bail};
use envpg_core::Registry;
use envpg_learner::{LearnerConfig, run_learner};
use envpg_transport::ipc;
use envpg_worker::{WorkerConfig, WorkerExit, run_worker};

use crate::run_dir::RunFile;

/// Exit code of a worker that refused the run's protocol version (not restarted).
pub const EXIT_PROTOCOL: u8 = 3;

/// One JSON progress line on stdout, read by the supervisor.
pub fn progress_line(p: &envpg_ac::trainer::Progress) -> String {
    serde_json::to_string(&crate::metrics::ProgressLine::from(p)).expect("progress serializes")
}

/// The learner process.
pub fn learner(dir: &Path, resume: bool, registry: &Registry) -> Result<()> {
    crate::log::keep_in(dir);
    crate::program::set_run_dir(dir);
    let run = RunFile::load(dir)?;
    let env = run.spec.load(registry)?;
    let resume_from = if resume { Some(run.load_checkpoint(dir)?) } else { None };
    let cfg = LearnerConfig {
        run_id: run.run_id.clone(),
        spec: run.spec.clone(),
        env,
        // Remote hosts' workers all come through one bridge port, but the learner tracks (and
        // queues tasks for) each of them.
        max_workers: run.workers.max(1) + 2 + if run.listen.is_some() { 64 } else { 0 },
        worker_timeout: Duration::from_millis(run.worker_timeout_ms),
        checkpoint: Some(run.checkpoint_policy(dir)),
        resume: resume_from,
        stall_timeout: Duration::from_secs(run.stall_timeout_s),
        collect_only: false,
    };
    let (result, stats) = run_learner::<ipc::Service>(&cfg, |p| {
        println!("{}", progress_line(p));
        true
    })?;
    crate::run_dir::save_result(&result, &run.out, dir)?;
    println!("{}", serde_json::json!({ "done": true, "J": result.j, "link": stats }));
    Ok(())
}

/// A worker process.
pub fn worker(dir: &Path, worker_id: u32, incarnation: u64, protocol: u32, registry: &Registry) -> Result<WorkerExit> {
    leave_with_parent();
    crate::log::keep_in(dir);
    crate::program::set_run_dir(dir);
    let run = RunFile::load(dir)?;
    let env = run.spec.load(registry)?;
    let cfg = WorkerConfig {
        run_id: run.run_id.clone(),
        spec: run.spec.clone(),
        env,
        worker_id,
        incarnation,
        protocol,
        join_timeout: Duration::from_secs(30),
        heartbeat: Duration::from_millis((run.worker_timeout_ms / 5).clamp(10, 500)),
        emulator_cost_us: run.emulator_cost_us,
        run_over: None,
    };
    match run_worker::<ipc::Service>(&cfg) {
        Ok(exit) => Ok(exit),
        Err(envpg_worker::WorkerError::Transport(e @ envpg_transport::TransportError::Version { .. })) => {
            eprintln!("error: {e}");
            std::process::exit(EXIT_PROTOCOL as i32);
        }
        Err(e) => bail!(e),
    }
}

/// A worker whose supervisor died (even by SIGKILL) gets SIGTERM and leaves cleanly, instead of
/// lingering as an orphan waiting for work that will never come.
fn leave_with_parent() {
    // SAFETY: prctl(PR_SET_PDEATHSIG) and getppid() only affect this process.
    unsafe {
        let parent = libc::getppid();
        libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGTERM);
        // The parent may have died before the prctl call.
        if libc::getppid() != parent {
            libc::raise(libc::SIGTERM);
        }
    }
}
