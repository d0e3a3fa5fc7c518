//! [`LearnerEnd`]: the learner's side of the link.

use envpg_protocol::{
    EpisodeHeader, EpisodeId, Hello, MAGIC, PROTOCOL_VERSION, RunInfo, ServiceNames, TaskHeader, WeightsHeader,
    run_id_bytes,
};
use iceoryx2::node::Node;
use iceoryx2::port::listener::Listener;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::publisher::Publisher;
use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::port::update_connections::UpdateConnections;
use iceoryx2::prelude::*;

use super::{LinkSizes, node, port_err, service_name, svc_err};
use crate::error::TransportError;

/// The learner's side of the link.
#[derive(Debug)]
pub struct LearnerEnd<S: Service> {
    node: Node<S>,
    names: ServiceNames,
    run_id: String,
    sizes: LinkSizes,
    run_info: Publisher<S, RunInfo, ()>,
    hello: Subscriber<S, Hello, ()>,
    weights: Publisher<S, [f32], WeightsHeader>,
    tasks: Publisher<S, [EpisodeId], TaskHeader>,
    episodes: Subscriber<S, [u32], EpisodeHeader>,
    wake_workers: Notifier<S>,
    wakeup: Listener<S>,
}

impl<S: Service> LearnerEnd<S> {
    /// Creates every service of run `run_id` with `sizes`.
    pub fn create(run_id: &str, sizes: LinkSizes) -> Result<Self, TransportError> {
        let node = node::<S>(&format!("envpg-learner-{run_id}"), SignalHandlingMode::HandleTerminationRequests)?;
        let names = ServiceNames::new(run_id);
        let ports = sizes.max_ports();

        let n = names.run_info();
        let run_info = node
            .service_builder(&service_name(&n)?)
            .publish_subscribe::<RunInfo>()
            .max_publishers(1)
            .max_subscribers(ports)
            .max_nodes(ports + 1)
            .history_size(1)
            .subscriber_max_buffer_size(2)
            .create()
            .map_err(|e| svc_err(&n, e))?
            .publisher_builder()
            .create()
            .map_err(|e| port_err("publisher", &n, e))?;

        let n = names.hello();
        let hello = node
            .service_builder(&service_name(&n)?)
            .publish_subscribe::<Hello>()
            .max_publishers(ports)
            .max_subscribers(2)
            .max_nodes(ports + 1)
            .subscriber_max_buffer_size(4 * ports + 64)
            .create()
            .map_err(|e| svc_err(&n, e))?
            .subscriber_builder()
            .buffer_size(4 * ports + 64)
            .create()
            .map_err(|e| port_err("subscriber", &n, e))?;

        let n = names.weights();
        let weights = node
            .service_builder(&service_name(&n)?)
            .publish_subscribe::<[f32]>()
            .user_header::<WeightsHeader>()
            .max_publishers(1)
            .max_subscribers(ports)
            .max_nodes(ports + 1)
            // The publisher's segment holds ports × (buffer + borrowed) + history + loaned
            // copies of θ, the largest message of a run: a worker only ever wants the newest
            // weights, reads them in place one at a time and copies them out at once.
            .history_size(1)
            .subscriber_max_buffer_size(1)
            .subscriber_max_borrowed_samples(1)
            .create()
            .map_err(|e| svc_err(&n, e))?
            .publisher_builder()
            .initial_max_slice_len(sizes.n_params.max(1))
            .max_loaned_samples(1)
            .create()
            .map_err(|e| port_err("publisher", &n, e))?;

        let n = names.tasks();
        let task_queue = 4 * sizes.max_workers + 16;
        let tasks = node
            .service_builder(&service_name(&n)?)
            .publish_subscribe::<[EpisodeId]>()
            .user_header::<TaskHeader>()
            .max_publishers(1)
            .max_subscribers(ports)
            .max_nodes(ports + 1)
            .subscriber_max_buffer_size(task_queue)
            .create()
            .map_err(|e| svc_err(&n, e))?
            .publisher_builder()
            .initial_max_slice_len(sizes.episodes_per_iteration.max(1))
            .max_loaned_samples(4)
            .create()
            .map_err(|e| port_err("publisher", &n, e))?;

        let n = names.episodes();
        // Workers only produce what the current iteration asked of them, so at most two copies
        // of each episode (its worker's and, after a reassignment, another's) are ever queued.
        // Every worker's segment holds subscribers × (queue + borrowed) + loaned episodes.
        let queue = 2 * sizes.episodes_per_iteration + 16;
        let episodes = node
            .service_builder(&service_name(&n)?)
            .publish_subscribe::<[u32]>()
            .user_header::<EpisodeHeader>()
            .max_publishers(ports)
            .max_subscribers(2)
            .max_nodes(ports + 1)
            .subscriber_max_borrowed_samples(1)
            .subscriber_max_buffer_size(queue)
            .create()
            .map_err(|e| svc_err(&n, e))?
            .subscriber_builder()
            .buffer_size(queue)
            .create()
            .map_err(|e| port_err("subscriber", &n, e))?;

        let n = names.worker_wakeup();
        let wake_workers = node
            .service_builder(&service_name(&n)?)
            .event()
            .max_notifiers(2)
            .max_listeners(ports)
            .max_nodes(ports + 1)
            .create()
            .map_err(|e| svc_err(&n, e))?
            .notifier_builder()
            .create()
            .map_err(|e| port_err("notifier", &n, e))?;

        let n = names.learner_wakeup();
        let wakeup = node
            .service_builder(&service_name(&n)?)
            .event()
            .max_notifiers(ports)
            .max_listeners(2)
            .max_nodes(ports + 1)
            .create()
            .map_err(|e| svc_err(&n, e))?
            .listener_builder()
            .create()
            .map_err(|e| port_err("listener", &n, e))?;

        Ok(Self {
            node,
            names,
            run_id: run_id.to_owned(),
            sizes,
            run_info,
            hello,
            weights,
            tasks,
            episodes,
            wake_workers,
            wakeup,
        })
    }

    /// The node (for WaitSets, dead-node cleanup and termination requests).
    pub fn node(&self) -> &Node<S> {
        &self.node
    }

    /// The listener woken by workers; attach it to a WaitSet.
    pub fn listener(&self) -> &Listener<S> {
        &self.wakeup
    }

    /// Announces the run (kept as history for late joiners); `finished` tells workers to leave.
    pub fn announce(&self, zeta_dim: usize, finished: bool) -> Result<(), TransportError> {
        let info = RunInfo {
            magic: MAGIC,
            protocol: PROTOCOL_VERSION,
            zeta_dim: zeta_dim as u32,
            n_params: self.sizes.n_params as u32,
            episode_cap: self.sizes.episode_cap as u32,
            run_id: run_id_bytes(&self.run_id),
            finished: u32::from(finished),
            _pad: 0,
        };
        self.run_info
            .send_copy(info)
            .map_err(|e| TransportError::Send { service: self.names.run_info(), reason: format!("{e:?}") })?;
        self.notify_workers()
    }

    /// Broadcasts θ_k, ζ_k and α_k for iteration `k`.
    pub fn publish_weights(&self, k: u64, alpha: f64, zeta: &[f64], params: &[f32]) -> Result<(), TransportError> {
        let service = self.names.weights();
        let send_err =
            |e: &dyn std::fmt::Debug| TransportError::Send { service: service.clone(), reason: format!("{e:?}") };
        if params.len() != self.sizes.n_params || zeta.len() > envpg_protocol::MAX_ZETA {
            return Err(TransportError::Malformed { service, reason: "weights do not match the link sizes".into() });
        }
        let mut sample = self.weights.loan_slice_uninit(params.len()).map_err(|e| send_err(&e))?;
        let h = sample.user_header_mut();
        h.protocol = PROTOCOL_VERSION;
        h.zeta_dim = zeta.len() as u32;
        h.run_id = run_id_bytes(&self.run_id);
        h.k = k;
        h.n_params = params.len() as u64;
        h.alpha = alpha;
        h.zeta = [0.0; envpg_protocol::MAX_ZETA];
        h.zeta[..zeta.len()].copy_from_slice(zeta);
        let sample = sample.write_from_slice(params);
        sample.send().map_err(|e| send_err(&e))?;
        Ok(())
    }

    /// Assigns `episodes` of iteration `k` to worker `worker_id` (incarnation `incarnation`).
    pub fn assign(
        &self,
        worker_id: u32,
        incarnation: u64,
        k: u64,
        episodes: &[EpisodeId],
    ) -> Result<(), TransportError> {
        let service = self.names.tasks();
        let send_err =
            |e: &dyn std::fmt::Debug| TransportError::Send { service: service.clone(), reason: format!("{e:?}") };
        let mut sample = self.tasks.loan_slice_uninit(episodes.len()).map_err(|e| send_err(&e))?;
        let h = sample.user_header_mut();
        h.protocol = PROTOCOL_VERSION;
        h.worker_id = worker_id;
        h.run_id = run_id_bytes(&self.run_id);
        h.k = k;
        h.incarnation = incarnation;
        sample.write_from_slice(episodes).send().map_err(|e| send_err(&e))?;
        Ok(())
    }

    /// Connects publishers to subscribers that appeared since the last send, delivering them
    /// the kept history (run info, latest weights). Call regularly: late joiners get nothing
    /// until the publisher side updates its connections.
    pub fn refresh(&self) {
        let _ = self.run_info.update_connections();
        let _ = self.weights.update_connections();
    }

    /// Wakes every worker's WaitSet.
    pub fn notify_workers(&self) -> Result<(), TransportError> {
        self.wake_workers
            .notify()
            .map(|_| ())
            .map_err(|e| TransportError::Send { service: self.names.worker_wakeup(), reason: format!("{e:?}") })
    }

    /// Drains the wake-up events (call after the WaitSet fired).
    pub fn drain_wakeups(&self) {
        let _ = self.wakeup.try_wait(|_| {});
    }

    /// All pending hello messages.
    pub fn receive_hellos(&self) -> Result<Vec<Hello>, TransportError> {
        let mut out = Vec::new();
        loop {
            match self.hello.receive() {
                Ok(Some(s)) => out.push(*s.payload()),
                Ok(None) => return Ok(out),
                Err(e) => {
                    return Err(TransportError::Receive { service: self.names.hello(), reason: format!("{e:?}") });
                }
            }
        }
    }

    /// Calls `f` with every pending episode message.
    pub fn receive_episodes(&self, mut f: impl FnMut(&EpisodeHeader, &[u32])) -> Result<usize, TransportError> {
        let mut n = 0;
        loop {
            match self.episodes.receive() {
                Ok(Some(s)) => {
                    f(s.user_header(), s.payload());
                    n += 1;
                }
                Ok(None) => return Ok(n),
                Err(e) => {
                    return Err(TransportError::Receive { service: self.names.episodes(), reason: format!("{e:?}") });
                }
            }
        }
    }

    /// Removes the resources of crashed nodes (e.g. a killed worker's ports), returning how many
    /// nodes were cleaned up.
    pub fn cleanup_dead_nodes(&self) -> usize {
        self.node.try_cleanup_dead_nodes().cleanups as usize
    }
}
