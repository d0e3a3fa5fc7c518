//! [`TransportError`]: one variant per kind of failure, each naming the service involved.

/// A failure of the iceoryx2 link.
#[derive(Debug, thiserror::Error)]
pub enum TransportError {
    /// The iceoryx2 node could not be created (e.g. no shared memory on this machine).
    #[error("cannot create the iceoryx2 node: {0} (if shared memory is unavailable here, run with --in-process)")]
    Node(String),
    /// A service name is not valid for iceoryx2.
    #[error("invalid service name {name:?}: {reason}")]
    Name {
        /// The name.
        name: String,
        /// Why.
        reason: String,
    },
    /// A service could not be created or opened.
    #[error("service {service}: {reason}")]
    Service {
        /// The service name.
        service: String,
        /// What iceoryx2 reported.
        reason: String,
    },
    /// A port (publisher, subscriber, notifier, listener) could not be created.
    #[error("{port} on service {service}: {reason}")]
    Port {
        /// Which port.
        port: &'static str,
        /// The service name.
        service: String,
        /// What iceoryx2 reported.
        reason: String,
    },
    /// Sending failed.
    #[error("sending on {service}: {reason}")]
    Send {
        /// The service name.
        service: String,
        /// What iceoryx2 reported.
        reason: String,
    },
    /// Receiving failed.
    #[error("receiving on {service}: {reason}")]
    Receive {
        /// The service name.
        service: String,
        /// What iceoryx2 reported.
        reason: String,
    },
    /// A message of the wrong shape arrived (size beyond the agreed limits).
    #[error("malformed message on {service}: {reason}")]
    Malformed {
        /// The service name.
        service: String,
        /// What is wrong.
        reason: String,
    },
    /// The learner did not appear in time.
    #[error("no learner for run {run_id} appeared within {seconds:.1} s")]
    NoLearner {
        /// The run id.
        run_id: String,
        /// How long we waited.
        seconds: f64,
    },
    /// SIGINT or SIGTERM while this worker was still joining.
    #[error("interrupted while joining run {run_id}")]
    Interrupted {
        /// The run id.
        run_id: String,
    },
    /// The run ended while this worker was still joining it.
    #[error("run {run_id} ended before this worker joined")]
    RunOver {
        /// The run id.
        run_id: String,
    },
    /// The peer speaks another protocol version.
    #[error(
        "protocol mismatch: the learner of run {run_id} speaks protocol version {learner}, this worker speaks version {worker}"
    )]
    Version {
        /// The run id.
        run_id: String,
        /// The learner's version.
        learner: u32,
        /// Ours.
        worker: u32,
    },
}
