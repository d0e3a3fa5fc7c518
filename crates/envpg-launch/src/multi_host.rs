//! Rollouts across hosts (feature `multi-host`): the learner host's bridge thread, and the
//! `worker --connect` role that runs worker processes for a learner on another host.
//!
//! Without the feature the same entry points exist and say how to enable it.

use std::time::Duration;

use anyhow::Result;

/// `--listen` / `--connect` in a binary built without the `multi-host` feature.
#[derive(Debug)]
pub struct NotBuilt;

impl std::fmt::Display for NotBuilt {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(
            "this envpg-launch was built without the `multi-host` feature; rebuild with \
             `cargo build --release --bin envpg-launch --features envpg-launch/multi-host`",
        )
    }
}

impl std::error::Error for NotBuilt {}

/// The worker host was interrupted (SIGINT/SIGTERM).
#[derive(Debug)]
pub struct HostInterrupted;

impl std::fmt::Display for HostInterrupted {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("interrupted: the worker processes of this host were stopped")
    }
}

impl std::error::Error for HostInterrupted {}

/// Errors that are the user's input (a peer of another protocol version counts: it is the
/// deployment that is wrong, not the computation).
pub fn is_input_error(e: &(dyn std::error::Error + 'static)) -> bool {
    matches!(
        e.downcast_ref::<envpg_bridge::BridgeError>(),
        Some(envpg_bridge::BridgeError::Version { .. } | envpg_bridge::BridgeError::Refused(_))
    )
}

/// Checks a zenoh TCP endpoint (`tcp/HOST:PORT`) and that this binary can use it.
pub fn check_listen(endpoint: &str) -> Result<()> {
    if !cfg!(feature = "multi-host") {
        return Err(NotBuilt.into());
    }
    check_endpoint(endpoint).map_err(|e| crate::InputError(e).into())
}

/// Checks a zenoh TCP endpoint: `tcp/HOST:PORT`.
pub fn check_endpoint(endpoint: &str) -> std::result::Result<(), String> {
    let bad = || format!("endpoint {endpoint:?}: expected tcp/HOST:PORT, e.g. tcp/0.0.0.0:7447 or tcp/10.0.0.1:7447");
    let rest = endpoint.strip_prefix("tcp/").ok_or_else(bad)?;
    let (host, port) = rest.rsplit_once(':').ok_or_else(bad)?;
    if host.is_empty() || port.parse::<u16>().is_err() {
        return Err(bad());
    }
    Ok(())
}

/// How `worker --connect` runs.
#[derive(Debug, Clone)]
#[cfg_attr(not(feature = "multi-host"), allow(dead_code))]
pub struct WorkerHost {
    /// The learner host's endpoint.
    pub endpoint: String,
    /// Worker processes here.
    pub workers: usize,
    /// Give up joining after this long.
    pub join_timeout: Duration,
    /// Leave after the learner host has been silent this long.
    pub link_timeout: Duration,
    /// Protocol version to announce (tests of version checks).
    pub protocol: u32,
}

#[cfg(not(feature = "multi-host"))]
mod imp {
    use super::*;
    use crate::run_dir::RunFile;

    /// Stand-in: the feature is off.
    pub struct LearnerBridgeThread;

    impl LearnerBridgeThread {
        pub fn failed(&mut self) -> Option<String> {
            None
        }
        pub fn finish(self) -> Result<serde_json::Value> {
            Ok(serde_json::Value::Null)
        }
    }

    pub fn start_learner_bridge(_run: &RunFile, _endpoint: &str) -> Result<LearnerBridgeThread> {
        Err(NotBuilt.into())
    }

    pub fn worker_host(_h: &WorkerHost, _registry: &envpg_core::Registry) -> Result<()> {
        Err(NotBuilt.into())
    }
}

#[cfg(feature = "multi-host")]
mod imp {
    use std::sync::Arc;
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::thread::JoinHandle;
    use std::time::Instant;

    use anyhow::{Context, bail};
    use envpg_bridge::{LearnerBridge, LearnerBridgeConfig, RemoteBridge, RemoteConfig};

    use super::*;
    use crate::run_dir::{RunFile, new_run_id};
    use crate::supervise::{WorkerPool, stop_all};

    /// How long a bridge waits on zenoh before looking at the iceoryx2 side again: it bounds
    /// the latency a hop adds (each iteration crosses the bridge twice each way), at the price
    /// of a wake-up per period when idle.
    const PUMP_WAIT: Duration = Duration::from_micros(250);

    /// How long the learner host's bridge stays up after the run for remote workers to leave:
    /// longer than the bridge's link lease (3 s) plus zenoh's reconnection period (≤ 4 s).
    const END_GRACE: Duration = Duration::from_secs(10);

    /// The learner host's bridge, relaying in a thread of the supervisor.
    pub struct LearnerBridgeThread {
        stop: Arc<AtomicBool>,
        handle: Option<JoinHandle<Result<serde_json::Value>>>,
        error: Option<String>,
    }

    impl LearnerBridgeThread {
        /// The bridge's error, if its thread ended early (it only ends by itself on one).
        pub fn failed(&mut self) -> Option<String> {
            if self.error.is_none()
                && let Some(h) = self.handle.take_if(|h| h.is_finished())
            {
                self.error = Some(match h.join() {
                    Ok(Ok(_)) => "it stopped unexpectedly".into(),
                    Ok(Err(e)) => format!("{e:#}"),
                    Err(_) => "its thread panicked".into(),
                });
            }
            self.error.clone()
        }

        /// Stops the bridge (after a moment to pass on the end of the run) and returns its
        /// traffic statistics.
        pub fn finish(mut self) -> Result<serde_json::Value> {
            self.stop.store(true, Ordering::SeqCst);
            match self.handle.take().map(|h| h.join()) {
                Some(Ok(r)) => r,
                Some(Err(_)) => bail!("the multi-host bridge thread panicked"),
                None => Ok(serde_json::Value::Null),
            }
        }
    }

    /// Starts the bridge thread for `run`, listening on `endpoint`.
    pub fn start_learner_bridge(run: &RunFile, endpoint: &str) -> Result<LearnerBridgeThread> {
        let cfg = LearnerBridgeConfig {
            listen: endpoint.to_owned(),
            run_id: run.run_id.clone(),
            run: serde_json::to_string(run)?,
            episodes_per_iteration: (run.spec.config.episodes + run.spec.config.explore_episodes) as u32,
            open_timeout: Duration::from_secs(30),
        };
        let stop = Arc::new(AtomicBool::new(false));
        let flag = stop.clone();
        let (tx, rx) = std::sync::mpsc::channel::<std::result::Result<(), String>>();
        let handle = std::thread::spawn(move || -> Result<serde_json::Value> {
            let mut bridge = match LearnerBridge::start(&cfg) {
                Ok(b) => {
                    let _ = tx.send(Ok(()));
                    b
                }
                Err(e) => {
                    let _ = tx.send(Err(e.to_string()));
                    return Err(e.into());
                }
            };
            while !flag.load(Ordering::SeqCst) {
                bridge.pump(PUMP_WAIT)?;
            }
            // Pass the end of the run on to the remote hosts: stay until their workers have
            // left, long enough for a host whose link broke at the end to reconnect and resync.
            let grace = Instant::now();
            while grace.elapsed() < Duration::from_millis(200)
                || (bridge.remote_workers() > 0 && grace.elapsed() < END_GRACE)
            {
                bridge.pump(PUMP_WAIT)?;
            }
            Ok(serde_json::to_value(bridge.stats())?)
        });
        // Listening problems (address in use, bad endpoint) surface here, before any work.
        match rx.recv_timeout(Duration::from_secs(40)) {
            Ok(Ok(())) => {}
            Ok(Err(e)) => bail!("cannot start the multi-host bridge on {endpoint}: {e}"),
            Err(_) => bail!("the multi-host bridge on {endpoint} did not start"),
        }
        Ok(LearnerBridgeThread { stop, handle: Some(handle), error: None })
    }

    fn host_name() -> String {
        let h = std::fs::read_to_string("/proc/sys/kernel/hostname").unwrap_or_else(|_| "host".into());
        format!("{}/{}", h.trim(), std::process::id())
    }

    /// `envpg-launch worker --connect`: joins the learner host, mirrors its run locally and
    /// runs `workers` worker processes (restarting crashed ones) until the run ends.
    pub fn worker_host(h: &WorkerHost, registry: &envpg_core::Registry) -> Result<()> {
        if h.workers == 0 {
            return Err(crate::InputError("--workers must be at least 1".into()).into());
        }
        check_endpoint(&h.endpoint).map_err(crate::InputError)?;
        let mut bridge = RemoteBridge::join(&RemoteConfig {
            connect: h.endpoint.clone(),
            host: host_name(),
            workers: h.workers as u32,
            join_timeout: h.join_timeout,
            protocol: h.protocol,
        })?;
        let joined = bridge.joined().clone();
        let mut run: RunFile = serde_json::from_str(&joined.run).context("the learner's run description")?;
        // The workers build the run's environment from its description: this build must know it.
        run.spec.load(registry).map_err(|e| {
            crate::InputError(format!(
                "this host cannot build the run's environment ({e}); use a build that registers it"
            ))
        })?;
        // A local run id: the mirror's services must not collide with a learner on this host.
        let local = new_run_id();
        let dir = std::env::temp_dir().join(format!("envpg-remote-{local}"));
        std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
        run.run_id = local.clone();
        run.workers = h.workers;
        run.listen = None;
        run.out = dir.join("unused.json");
        run.save(&dir)?;
        bridge.start(&local)?;
        eprintln!(
            "joined run {} at {}: {} worker(s) here, global ids {}..{}",
            joined.run_id,
            h.endpoint,
            h.workers,
            joined.id_base,
            joined.id_base as usize + h.workers - 1
        );
        let mut workers = WorkerPool::start(&dir, h.workers, h.protocol, 20)?;
        let mut last_check = Instant::now();
        let mut last_heard = Instant::now();
        let mut announced = false;
        let result = loop {
            if bridge.node().is_some_and(|n| n.wait(Duration::ZERO).is_err()) {
                break Err(HostInterrupted.into());
            }
            let before = bridge.received();
            if let Err(e) = bridge.pump(PUMP_WAIT) {
                break Err(e.into());
            }
            if !announced && bridge.episodes_sent() > 0 {
                announced = true;
                eprintln!("this host's workers are running: first episodes sent to the learner host");
            }
            if bridge.received() != before {
                last_heard = Instant::now();
            } else if last_heard.elapsed() > h.link_timeout {
                break Err(anyhow::anyhow!(
                    "the learner host at {} has been silent for {:.0} s; leaving",
                    h.endpoint,
                    h.link_timeout.as_secs_f64()
                ));
            }
            if last_check.elapsed() < Duration::from_millis(50) {
                continue;
            }
            last_check = Instant::now();
            if let Err(e) = workers.check(bridge.finished()) {
                break Err(e);
            }
            if workers.all_stopped() {
                break if bridge.finished() {
                    Ok(())
                } else {
                    Err(anyhow::anyhow!("every worker process of this host has stopped before the end of the run"))
                };
            }
        };
        stop_all(&mut workers.running(), Duration::from_secs(3));
        let _ = std::fs::remove_dir_all(&dir);
        if result.is_ok() {
            eprintln!("run {} finished", joined.run_id);
        }
        result
    }
}

pub use imp::*;
