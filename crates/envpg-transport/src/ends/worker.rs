//! [`WorkerEnd`]: a worker's side of the link.

use std::time::{Duration, Instant};

use envpg_protocol::{
    EpisodeHeader, EpisodeId, Hello, MAGIC, PROTOCOL_VERSION, RunInfo, ServiceNames, TaskHeader, WeightsHeader,
    run_id_bytes, step_words,
};
use iceoryx2::node::Node;
use iceoryx2::port::listener::Listener;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;
use iceoryx2::service::builder::event::EventOpenError;
use iceoryx2::service::builder::publish_subscribe::PublishSubscribeOpenError;

use super::{node, port_err, service_name, svc_err};
use crate::error::TransportError;

/// A worker's side of the link.
#[derive(Debug)]
pub struct WorkerEnd<S: Service> {
    node: Node<S>,
    names: ServiceNames,
    run_id: String,
    info: std::cell::Cell<RunInfo>,
    run_info: Subscriber<S, RunInfo, ()>,
    hello: Publisher<S, Hello, ()>,
    weights: Subscriber<S, [f32], WeightsHeader>,
    tasks: Subscriber<S, [EpisodeId], TaskHeader>,
    episodes: Publisher<S, [u32], EpisodeHeader>,
    wake_learner: Notifier<S>,
    wakeup: Listener<S>,
}

impl<S: Service> WorkerEnd<S> {
    /// Joins run `run_id`: waits up to `timeout` for the learner's run info, checks its
    /// protocol version (announcing `protocol` ourselves — normally [`PROTOCOL_VERSION`]), then
    /// opens the versioned services.
    pub fn open(run_id: &str, worker_id: u32, protocol: u32, timeout: Duration) -> Result<Self, TransportError> {
        Self::open_while(run_id, worker_id, protocol, timeout, &|| true, SignalHandlingMode::HandleTerminationRequests)
    }

    /// As [`WorkerEnd::open`], giving up with [`TransportError::RunOver`] as soon as
    /// `keep_waiting` says no: a worker thread of an in-process run whose learner already
    /// returned (the other workers did all the work) then leaves at once. `signals` is how
    /// the end's node treats SIGINT/SIGTERM while it waits: iceoryx2 keeps one termination flag
    /// per process and the first node or WaitSet to look clears it, so a worker *thread* of a
    /// process whose learner must see the signal passes [`SignalHandlingMode::Disabled`].
    pub fn open_while(
        run_id: &str,
        worker_id: u32,
        protocol: u32,
        timeout: Duration,
        keep_waiting: &dyn Fn() -> bool,
        signals: SignalHandlingMode,
    ) -> Result<Self, TransportError> {
        let node = node::<S>(&format!("envpg-worker{worker_id}-{run_id}"), signals)?;
        let names = ServiceNames::new(run_id);
        let start = Instant::now();
        let n = names.run_info();
        let run_info_service = loop {
            match node.service_builder(&service_name(&n)?).publish_subscribe::<RunInfo>().open() {
                Ok(s) => break s,
                Err(_) if !keep_waiting() => return Err(TransportError::RunOver { run_id: run_id.to_owned() }),
                Err(e) if start.elapsed() < timeout => {
                    tracing::debug!("waiting for the learner's run info: {e:?}");
                    if node.wait(Duration::from_millis(20)).is_err() {
                        return Err(TransportError::Interrupted { run_id: run_id.to_owned() });
                    }
                }
                Err(_) => {
                    return Err(TransportError::NoLearner {
                        run_id: run_id.to_owned(),
                        seconds: timeout.as_secs_f64(),
                    });
                }
            }
        };
        let run_info = run_info_service
            .subscriber_builder()
            .history_request(1)
            .create()
            .map_err(|e| port_err("subscriber", &n, e))?;
        let info = loop {
            match run_info.receive() {
                Ok(Some(s)) => break *s.payload(),
                Ok(None) if !keep_waiting() => return Err(TransportError::RunOver { run_id: run_id.to_owned() }),
                Ok(None) if start.elapsed() < timeout => {
                    if node.wait(Duration::from_millis(5)).is_err() {
                        return Err(TransportError::Interrupted { run_id: run_id.to_owned() });
                    }
                }
                Ok(None) => {
                    return Err(TransportError::NoLearner {
                        run_id: run_id.to_owned(),
                        seconds: timeout.as_secs_f64(),
                    });
                }
                Err(e) => return Err(TransportError::Receive { service: n, reason: format!("{e:?}") }),
            }
        };
        if info.finished != 0 {
            return Err(TransportError::RunOver { run_id: run_id.to_owned() });
        }
        // The learner announced the run, so its services exist unless it has ended since: a
        // service gone now means the run is over (the other workers did the work), not a broken
        // link.
        let ps_err = |n: &str, e: PublishSubscribeOpenError| match e {
            PublishSubscribeOpenError::DoesNotExist => TransportError::RunOver { run_id: run_id.to_owned() },
            e => svc_err(n, e),
        };
        let ev_err = |n: &str, e: EventOpenError| match e {
            EventOpenError::DoesNotExist => TransportError::RunOver { run_id: run_id.to_owned() },
            e => svc_err(n, e),
        };
        let n = names.hello();
        let hello = node
            .service_builder(&service_name(&n)?)
            .publish_subscribe::<Hello>()
            .open()
            .map_err(|e| ps_err(&n, e))?
            .publisher_builder()
            .create()
            .map_err(|e| port_err("publisher", &n, e))?;
        if info.magic != MAGIC || info.protocol != protocol {
            // Tell the learner why we leave, in the version-agnostic format, then refuse.
            let refuse = Hello {
                magic: MAGIC,
                protocol,
                kind: envpg_protocol::hello_kind::REFUSE,
                worker_id,
                pid: std::process::id(),
                incarnation: 0,
                run_id: run_id_bytes(run_id),
                detail: u64::from(info.protocol),
            };
            let _ = hello.send_copy(refuse);
            // A publisher's samples vanish with it: linger so the learner can read the refusal.
            let _ = node.wait(Duration::from_millis(300));
            return Err(TransportError::Version {
                run_id: run_id.to_owned(),
                learner: info.protocol,
                worker: protocol,
            });
        }
        let n = names.weights();
        let weights = node
            .service_builder(&service_name(&n)?)
            .publish_subscribe::<[f32]>()
            .user_header::<WeightsHeader>()
            .open()
            .map_err(|e| ps_err(&n, e))?
            .subscriber_builder()
            .history_request(1)
            .create()
            .map_err(|e| port_err("subscriber", &n, e))?;
        let n = names.tasks();
        let tasks = node
            .service_builder(&service_name(&n)?)
            .publish_subscribe::<[EpisodeId]>()
            .user_header::<TaskHeader>()
            .open()
            .map_err(|e| ps_err(&n, e))?
            .subscriber_builder()
            .create()
            .map_err(|e| port_err("subscriber", &n, e))?;
        let n = names.episodes();
        let episodes = node
            .service_builder(&service_name(&n)?)
            .publish_subscribe::<[u32]>()
            .user_header::<EpisodeHeader>()
            .open()
            .map_err(|e| ps_err(&n, e))?
            .publisher_builder()
            .initial_max_slice_len((info.episode_cap as usize * step_words(info.zeta_dim as usize)).max(1))
            .max_loaned_samples(1)
            .create()
            .map_err(|e| port_err("publisher", &n, e))?;
        let n = names.learner_wakeup();
        let wake_learner = node
            .service_builder(&service_name(&n)?)
            .event()
            .open()
            .map_err(|e| ev_err(&n, e))?
            .notifier_builder()
            .create()
            .map_err(|e| port_err("notifier", &n, e))?;
        let n = names.worker_wakeup();
        let wakeup = node
            .service_builder(&service_name(&n)?)
            .event()
            .open()
            .map_err(|e| ev_err(&n, e))?
            .listener_builder()
            .create()
            .map_err(|e| port_err("listener", &n, e))?;
        // Connect the subscribers before announcing ourselves: messages sent to a subscriber
        // that has not connected yet can be lost.
        let _ = tasks.has_samples();
        let _ = weights.has_samples();
        Ok(Self {
            node,
            names,
            run_id: run_id.to_owned(),
            info: std::cell::Cell::new(info),
            run_info,
            hello,
            weights,
            tasks,
            episodes,
            wake_learner,
            wakeup,
        })
    }

    /// The node (for WaitSets and termination requests).
    pub fn node(&self) -> &Node<S> {
        &self.node
    }

    /// The listener woken by the learner; attach it to a WaitSet.
    pub fn listener(&self) -> &Listener<S> {
        &self.wakeup
    }

    /// The latest run info.
    pub fn info(&self) -> RunInfo {
        self.info.get()
    }

    /// Whether the learner announced the end of the run.
    pub fn run_finished(&self) -> Result<bool, TransportError> {
        loop {
            match self.run_info.receive() {
                Ok(Some(s)) => self.info.set(*s.payload()),
                Ok(None) => return Ok(self.info.get().finished != 0),
                Err(e) => {
                    return Err(TransportError::Receive { service: self.names.run_info(), reason: format!("{e:?}") });
                }
            }
        }
    }

    /// Sends a hello of `kind` for worker `worker_id`, incarnation `incarnation`, and wakes the
    /// learner.
    pub fn say(&self, kind: u32, worker_id: u32, incarnation: u64) -> Result<(), TransportError> {
        let msg = Hello {
            magic: MAGIC,
            protocol: PROTOCOL_VERSION,
            kind,
            worker_id,
            pid: std::process::id(),
            incarnation,
            run_id: run_id_bytes(&self.run_id),
            detail: 0,
        };
        self.hello
            .send_copy(msg)
            .map_err(|e| TransportError::Send { service: self.names.hello(), reason: format!("{e:?}") })?;
        self.notify_learner()
    }

    /// Forwards a hello on behalf of another process (a bridge relaying remote workers): the
    /// message as given, re-addressed to this run; wakes the learner.
    pub fn forward_hello(&self, mut msg: Hello) -> Result<(), TransportError> {
        msg.magic = MAGIC;
        msg.run_id = run_id_bytes(&self.run_id);
        self.hello
            .send_copy(msg)
            .map_err(|e| TransportError::Send { service: self.names.hello(), reason: format!("{e:?}") })?;
        self.notify_learner()
    }

    /// The run id this end belongs to.
    pub fn run_id(&self) -> &str {
        &self.run_id
    }

    /// The newest weights message, if one arrived since the last call.
    pub fn latest_weights(&self) -> Result<Option<(WeightsHeader, Vec<f32>)>, TransportError> {
        let mut out = None;
        self.with_latest_weights(|h, p| out = Some((*h, p.to_vec())))?;
        Ok(out)
    }

    /// Calls `f` with the newest weights message, read in place from shared memory, if one
    /// arrived since the last call; returns whether it did.
    pub fn with_latest_weights(&self, f: impl FnOnce(&WeightsHeader, &[f32])) -> Result<bool, TransportError> {
        let err = |e: &dyn std::fmt::Debug| TransportError::Receive {
            service: self.names.weights(),
            reason: format!("{e:?}"),
        };
        // One sample borrowed at a time (the service allows no more): a newer one that arrived
        // meanwhile replaces it.
        loop {
            let Some(sample) = self.weights.receive().map_err(|e| err(&e))? else { return Ok(false) };
            if !self.weights.has_samples().map_err(|e| err(&e))? {
                f(sample.user_header(), sample.payload());
                return Ok(true);
            }
        }
    }

    /// Every task message that arrived since the last call (for any worker; filter by id).
    pub fn take_tasks(&self) -> Result<Vec<(TaskHeader, Vec<EpisodeId>)>, TransportError> {
        let mut out = Vec::new();
        loop {
            match self.tasks.receive() {
                Ok(Some(s)) => out.push((*s.user_header(), s.payload().to_vec())),
                Ok(None) => return Ok(out),
                Err(e) => {
                    return Err(TransportError::Receive { service: self.names.tasks(), reason: format!("{e:?}") });
                }
            }
        }
    }

    /// Publishes one episode under `header`: `header.len` steps of
    /// [`step_words`]`(header.zeta_dim)` words each ([`envpg_protocol::write_step`]), at most
    /// the run's episode cap (no wake-up; call [`WorkerEnd::notify_learner`] once per batch).
    pub fn publish_episode(&self, header: EpisodeHeader, words: &[u32]) -> Result<(), TransportError> {
        let service = self.names.episodes();
        let send_err =
            |e: &dyn std::fmt::Debug| TransportError::Send { service: service.clone(), reason: format!("{e:?}") };
        // Only what fits the run's messages is checked here; whether the words agree with the
        // header is the learner's to check, as for any peer.
        let info = self.info.get();
        let max = info.episode_cap as usize * step_words(info.zeta_dim as usize);
        if words.len() > max {
            return Err(TransportError::Malformed {
                service,
                reason: format!("an episode of {} words exceeds the run's {max} (its episode cap)", words.len()),
            });
        }
        let mut sample = self.episodes.loan_slice_uninit(words.len()).map_err(|e| send_err(&e))?;
        *sample.user_header_mut() = header;
        sample.write_from_slice(words).send().map_err(|e| send_err(&e))?;
        Ok(())
    }

    /// Wakes the learner's WaitSet.
    pub fn notify_learner(&self) -> Result<(), TransportError> {
        self.wake_learner
            .notify()
            .map(|_| ())
            .map_err(|e| TransportError::Send { service: self.names.learner_wakeup(), reason: format!("{e:?}") })
    }

    /// Drains the wake-up events (call after the WaitSet fired).
    pub fn drain_wakeups(&self) {
        let _ = self.wakeup.try_wait(|_| {});
    }
}
