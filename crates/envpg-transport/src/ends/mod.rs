//! [`LearnerEnd`] and [`WorkerEnd`], one file each, and what both need: the [`LinkSizes`] they
//! agree on, node and service names, and error mapping.

use iceoryx2::node::Node;
use iceoryx2::prelude::*;

use crate::error::TransportError;

mod learner;
mod worker;

pub use learner::LearnerEnd;
pub use worker::WorkerEnd;

/// Limits both ends agree on; the learner creates services with them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LinkSizes {
    /// Most workers alive at once, replacements included.
    pub max_workers: usize,
    /// Actor parameters per weights message.
    pub n_params: usize,
    /// Records per episode message at most.
    pub episode_cap: usize,
    /// Episodes per iteration (bounds task messages and the episode queue).
    pub episodes_per_iteration: usize,
}

impl LinkSizes {
    fn max_ports(&self) -> usize {
        // Replacements of crashed workers may briefly coexist with their predecessors' stale
        // ports until those are cleaned up.
        2 * self.max_workers + 8
    }
}

/// Silences iceoryx2's own log lines (e.g. "no config file was loaded") unless `IOX2_LOG_LEVEL`
/// asks for them.
pub fn quiet_iceoryx2_logs() {
    set_log_level_from_env_or(LogLevel::Error);
}

fn service_name(name: &str) -> Result<ServiceName, TransportError> {
    ServiceName::new(name).map_err(|e| TransportError::Name { name: name.to_owned(), reason: format!("{e:?}") })
}

fn svc_err(service: &str, e: impl std::fmt::Debug) -> TransportError {
    TransportError::Service { service: service.to_owned(), reason: format!("{e:?}") }
}

fn port_err(port: &'static str, service: &str, e: impl std::fmt::Debug) -> TransportError {
    TransportError::Port { port, service: service.to_owned(), reason: format!("{e:?}") }
}

fn node<S: Service>(name: &str, signals: SignalHandlingMode) -> Result<Node<S>, TransportError> {
    let node_name = NodeName::new(name).map_err(|e| TransportError::Node(format!("{e:?}")))?;
    // Creating a node cleans up dead ones, which hangs on a segment its creator never sized.
    for path in crate::remove_unfinished_segments() {
        tracing::warn!(path = %path.display(), "removed a shared-memory segment whose creator died before sizing it");
    }
    NodeBuilder::new()
        .name(&node_name)
        .signal_handling_mode(signals)
        .create::<S>()
        .map_err(|e| TransportError::Node(format!("{e:?}")))
}
