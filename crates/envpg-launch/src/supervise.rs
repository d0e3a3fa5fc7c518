//! The supervisor: starts the learner and worker processes, restarts crashed workers, streams
//! progress, forwards termination, and cleans up.

use std::io::BufRead;
use std::path::{Path, PathBuf};
use std::process::{Child, ExitStatus, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use anyhow::{Result, anyhow, bail};
use envpg_transport::SHM_DIR;
use iceoryx2::prelude::*;

use crate::roles::EXIT_PROTOCOL;
use crate::run_dir::RunFile;

/// What to supervise.
#[derive(Debug, Clone)]
pub struct Launch {
    /// Run directory (run.json, checkpoint).
    pub dir: PathBuf,
    /// Continue from the checkpoint.
    pub resume: bool,
    /// Protocol version the workers announce (tests of version mismatches).
    pub worker_protocol: u32,
    /// Restarts allowed per worker slot.
    pub max_restarts: u32,
}

/// What happened.
#[derive(Debug, Default)]
pub struct Outcome {
    /// Workers restarted after a crash.
    pub restarts: u32,
    /// Stale iceoryx2 nodes of crashed runs removed at start.
    pub stale_removed: usize,
    /// The learner's final line.
    pub done: Option<serde_json::Value>,
    /// Traffic through the multi-host bridge, if one ran.
    pub bridge: Option<serde_json::Value>,
}

/// Removes the resources of dead iceoryx2 nodes (from runs killed with SIGKILL); returns how
/// many were removed.
pub fn remove_stale_nodes() -> usize {
    let mut dead = Vec::new();
    let _ = Node::<ipc::Service>::list(Config::global_config(), |state| {
        if let NodeState::Dead(view) = state {
            dead.push(view);
        }
        CallbackProgression::Continue
    });
    dead.into_iter().filter(|view| view.clone().try_remove_stale_resources().is_ok()).count()
}

/// Asks `child` to stop (SIGTERM).
pub(crate) fn terminate(child: &Child) {
    // SAFETY: plain kill(2) on a pid we spawned.
    unsafe {
        libc::kill(child.id() as libc::pid_t, libc::SIGTERM);
    }
}

/// Starts this launcher program ([`crate::program`]) with `args` (stdout piped if asked).
pub(crate) fn spawn(args: &[String], stdout: bool) -> Result<Child> {
    let mut cmd = crate::program::command(args)?;
    cmd.stdin(Stdio::null());
    if stdout {
        cmd.stdout(Stdio::piped());
    }
    Ok(cmd.spawn()?)
}

struct Slot {
    child: Option<Child>,
    incarnation: u64,
    restarts: u32,
}

/// The worker processes of one host, each in a slot that a crashed worker's replacement takes
/// over (with the next incarnation); used by the local supervisor and by `worker --connect`.
pub(crate) struct WorkerPool {
    dir: PathBuf,
    protocol: u32,
    max_restarts: u32,
    slots: Vec<Slot>,
    /// Workers restarted after a crash.
    pub(crate) restarts: u32,
}

impl WorkerPool {
    /// Starts `n` workers of the run in `dir`, announcing `protocol`.
    pub(crate) fn start(dir: &Path, n: usize, protocol: u32, max_restarts: u32) -> Result<Self> {
        let mut pool = Self { dir: dir.to_owned(), protocol, max_restarts, slots: Vec::with_capacity(n), restarts: 0 };
        for i in 0..n {
            let child = spawn(&pool.args(i, 1), false)?;
            pool.slots.push(Slot { child: Some(child), incarnation: 1, restarts: 0 });
        }
        Ok(pool)
    }

    fn args(&self, id: usize, incarnation: u64) -> Vec<String> {
        vec![
            "worker".into(),
            "--run-dir".into(),
            self.dir.display().to_string(),
            "--worker-id".into(),
            id.to_string(),
            "--incarnation".into(),
            incarnation.to_string(),
            "--protocol-version".into(),
            self.protocol.to_string(),
        ]
    }

    /// Reaps exited workers and restarts crashed ones. A worker that exits cleanly, or any exit
    /// once `run_over`, ends its slot; so does a protocol refusal or too many restarts.
    pub(crate) fn check(&mut self, run_over: bool) -> Result<()> {
        for i in 0..self.slots.len() {
            let slot = &mut self.slots[i];
            let Some(child) = slot.child.as_mut() else { continue };
            let Some(s) = child.try_wait()? else { continue };
            if let Some(e) = shm_exhausted(&format!("worker {i}"), &s) {
                // A replacement would die the same way.
                return Err(e);
            }
            if s.code() == Some(i32::from(crate::program::EXIT_ENV)) {
                return Err(crate::program::env_failure(&self.dir, &format!("worker {i}")));
            }
            if s.success() || run_over {
                // It saw the end of the run.
                slot.child = None;
            } else if s.code() == Some(EXIT_PROTOCOL as i32) {
                eprintln!("worker {i} refused the run (protocol version mismatch); not restarting it");
                slot.child = None;
            } else if slot.restarts >= self.max_restarts {
                eprintln!(
                    "worker {i} exited ({}) and has been restarted {} times already; giving up on it",
                    describe(&s),
                    slot.restarts
                );
                slot.child = None;
            } else {
                slot.restarts += 1;
                slot.incarnation += 1;
                self.restarts += 1;
                eprintln!("worker {i} exited ({}); starting a replacement", describe(&s));
                let incarnation = slot.incarnation;
                self.slots[i].child = Some(spawn(&self.args(i, incarnation), false)?);
            }
        }
        Ok(())
    }

    /// Whether every slot has ended (the worker host's exit test).
    #[cfg_attr(not(feature = "multi-host"), allow(dead_code))]
    pub(crate) fn all_stopped(&self) -> bool {
        self.slots.iter().all(|s| s.child.is_none())
    }

    /// The workers still running.
    pub(crate) fn running(&mut self) -> Vec<&mut Child> {
        self.slots.iter_mut().filter_map(|s| s.child.as_mut()).collect()
    }
}

/// Waits up to `grace` for `children` to exit, terminating then killing stragglers.
pub(crate) fn stop_all(children: &mut [&mut Child], grace: Duration) {
    let start = Instant::now();
    for c in children.iter() {
        terminate(c);
    }
    while start.elapsed() < grace {
        if children.iter_mut().all(|c| c.try_wait().ok().flatten().is_some()) {
            return;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    for c in children.iter_mut() {
        let _ = c.kill();
        let _ = c.wait();
    }
}

/// A child's exit status in words.
pub(crate) fn describe(s: &ExitStatus) -> String {
    use std::os::unix::process::ExitStatusExt;
    match (s.code(), s.signal()) {
        (Some(c), _) => format!("exit code {c}"),
        (None, Some(sig)) => format!("signal {sig}"),
        _ => "unknown status".into(),
    }
}

/// A process of the run killed by SIGBUS touched shared memory that `/dev/shm` could not back
/// (tmpfs hands out segments lazily and faults when full: Docker's default is 64 MB). That is
/// the machine's limit, not a bug of the run: an input error (exit 2) saying where, how full
/// and what to do.
pub(crate) fn shm_exhausted(who: &str, s: &ExitStatus) -> Option<anyhow::Error> {
    use std::os::unix::process::ExitStatusExt;
    (s.signal() == Some(libc::SIGBUS)).then(|| {
        crate::InputError(format!(
            "{who} was killed by SIGBUS: the shared memory in {SHM_DIR} ran out ({}). Give {SHM_DIR} \
             more room (Docker: `--shm-size=1g`), or train with --in-process, which needs no shared memory",
            shm_usage()
        ))
        .into()
    })
}

/// `/dev/shm`'s free and total space, and what iceoryx2's segments there reserve.
fn shm_usage() -> String {
    let mib = |b: u64| b as f64 / (1024.0 * 1024.0);
    // SAFETY: `statvfs` is a plain C struct of integers, for which all zeros is a valid value.
    let mut st: libc::statvfs = unsafe { std::mem::zeroed() };
    let path = std::ffi::CString::new(SHM_DIR).expect("no NUL");
    // SAFETY: statvfs(3) fills `st` for a NUL-terminated path.
    let space = if unsafe { libc::statvfs(path.as_ptr(), &mut st) } == 0 {
        let frsize = st.f_frsize as u64;
        format!("{:.1} MiB free of {:.1} MiB", mib(st.f_bavail as u64 * frsize), mib(st.f_blocks as u64 * frsize))
    } else {
        "its size is unknown".into()
    };
    let reserved: u64 = std::fs::read_dir(SHM_DIR)
        .map(|d| {
            d.filter_map(|e| e.ok())
                .filter(|e| e.file_name().to_string_lossy().starts_with("iox2_"))
                .filter_map(|e| e.metadata().ok())
                .map(|m| m.len())
                .sum()
        })
        .unwrap_or(0);
    format!("{space}; iceoryx2's segments there reserve {:.1} MiB, of which the pages touched must fit", mib(reserved))
}

/// Reads the learner's remaining lines (until its stdout closes, or 200 ms of silence).
fn drain_lines(rx: &mpsc::Receiver<String>, out: &mut Outcome, progress: &mut impl FnMut(&serde_json::Value)) {
    while let Ok(line) = rx.recv_timeout(Duration::from_millis(200)) {
        if let Ok(v) = serde_json::from_str::<serde_json::Value>(&line) {
            if v.get("done").is_some() {
                out.done = Some(v);
            } else {
                progress(&v);
            }
        }
    }
}

/// Runs the learner and workers of `l` to completion; `progress` gets the learner's JSON lines.
pub fn supervise(l: &Launch, mut progress: impl FnMut(&serde_json::Value)) -> Result<Outcome> {
    let run = RunFile::load(&l.dir)?;
    // First the segments of processes that died creating them: cleaning up their dead nodes
    // would otherwise wait for them without end.
    let unfinished = envpg_transport::remove_unfinished_segments();
    if !unfinished.is_empty() {
        eprintln!(
            "removed {} shared-memory segment(s) left empty by a process that died creating them",
            unfinished.len()
        );
    }
    let mut out = Outcome { stale_removed: remove_stale_nodes(), ..Default::default() };
    if out.stale_removed > 0 {
        eprintln!(
            "removed the shared-memory resources of {} iceoryx2 node(s) left behind by a run that died",
            out.stale_removed
        );
    }
    // A node of our own makes SIGINT/SIGTERM observable without a custom signal handler.
    let node = NodeBuilder::new()
        .signal_handling_mode(SignalHandlingMode::HandleTerminationRequests)
        .create::<ipc::Service>()
        .map_err(|e| {
            anyhow!(
                "cannot create an iceoryx2 node: {e:?} (if shared memory is unavailable here, run with --in-process)"
            )
        })?;

    let mut learner_args = vec!["learner".to_string(), "--run-dir".into(), l.dir.display().to_string()];
    if l.resume {
        learner_args.push("--resume".into());
    }
    let mut learner = spawn(&learner_args, true)?;
    let (tx, rx) = mpsc::channel::<String>();
    let stdout = learner.stdout.take().expect("piped");
    std::thread::spawn(move || {
        for line in std::io::BufReader::new(stdout).lines().map_while(Result::ok) {
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    // Remote worker hosts reach the learner through a bridge thread of this process.
    let mut bridge = match &run.listen {
        Some(endpoint) => match crate::multi_host::start_learner_bridge(&run, endpoint) {
            Ok(b) => Some(b),
            Err(e) => {
                stop_all(&mut [&mut learner], Duration::from_secs(5));
                node.try_cleanup_dead_nodes();
                return Err(e);
            }
        },
        None => None,
    };
    let mut workers = WorkerPool::start(&l.dir, run.workers, l.worker_protocol, l.max_restarts)?;

    let status = loop {
        if node.wait(Duration::from_millis(25)).is_err() {
            // The learner checkpoints its last completed iteration on SIGTERM: tell it first,
            // and give it time to finish writing (a further signal does not cut the write).
            terminate(&learner);
            stop_all(&mut workers.running(), Duration::from_secs(5));
            stop_all(&mut [&mut learner], Duration::from_secs(120));
            // A learner past training (in the ζ polish) finishes and writes its result instead.
            if let Ok(Some(s)) = learner.try_wait()
                && s.success()
            {
                break s;
            }
            // The iterations it completed before stopping still reach the metrics.
            drain_lines(&rx, &mut out, &mut progress);
            node.try_cleanup_dead_nodes();
            bail!(Interrupted);
        }
        while let Ok(line) = rx.try_recv() {
            match serde_json::from_str::<serde_json::Value>(&line) {
                Ok(v) if v.get("done").is_some() => out.done = Some(v),
                Ok(v) => progress(&v),
                Err(_) => eprintln!("{line}"),
            }
        }
        if let Some(s) = learner.try_wait()? {
            break s;
        }
        if let Some(b) = bridge.as_mut()
            && let Some(e) = b.failed()
        {
            let mut all = workers.running();
            all.push(&mut learner);
            stop_all(&mut all, Duration::from_secs(5));
            node.try_cleanup_dead_nodes();
            bail!("the multi-host bridge failed: {e}");
        }
        if let Err(e) = workers.check(false) {
            let mut all = workers.running();
            all.push(&mut learner);
            stop_all(&mut all, Duration::from_secs(5));
            node.try_cleanup_dead_nodes();
            return Err(e);
        }
    };
    // Said with /dev/shm as the learner left it (before the dead nodes' segments are removed).
    if let Some(e) = shm_exhausted("the learner", &status) {
        stop_all(&mut workers.running(), Duration::from_secs(3));
        node.try_cleanup_dead_nodes();
        return Err(e);
    }
    if status.code() == Some(i32::from(crate::program::EXIT_ENV)) {
        stop_all(&mut workers.running(), Duration::from_secs(3));
        node.try_cleanup_dead_nodes();
        return Err(crate::program::env_failure(&l.dir, "the learner"));
    }
    drain_lines(&rx, &mut out, &mut progress);
    // Workers leave by themselves once the learner announces the end; give them a moment.
    out.restarts = workers.restarts;
    let mut rest = workers.running();
    let grace = Instant::now();
    while grace.elapsed() < Duration::from_secs(2) && rest.iter_mut().any(|c| c.try_wait().ok().flatten().is_none()) {
        std::thread::sleep(Duration::from_millis(20));
    }
    stop_all(&mut rest, Duration::from_secs(3));
    if let Some(b) = bridge {
        out.bridge = Some(b.finish()?);
    }
    node.try_cleanup_dead_nodes();
    if status.code() == Some(130) {
        // The learner alone was signalled: it checkpointed and stopped.
        bail!(Interrupted);
    }
    if !status.success() {
        bail!("the learner failed ({})", describe(&status));
    }
    Ok(out)
}

/// The run was interrupted by SIGINT/SIGTERM.
#[derive(Debug)]
pub struct Interrupted;

impl std::fmt::Display for Interrupted {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("interrupted: every process of the run was stopped")
    }
}

impl std::error::Error for Interrupted {}
