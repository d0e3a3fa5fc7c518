//! # envpg-bridge
//!
//! Rollouts across hosts. Local workers keep zero-copy iceoryx2; workers on another host reach
//! the learner through a thin bridge of envpg's own protocol over zenoh, with blocking
//! congestion control so backpressure holds end to end.
//!
//! ## Main types
//! - [`wire`]: the messages on the wire (postcard): [`wire::Down`] (learner → remote hosts:
//!   run info, weights, tasks), [`wire::Up`] (remote hosts → learner: hellos, episodes), and the
//!   version-agnostic join exchange.
//! - `LearnerBridge` (feature `multi-host`): on the learner host, a proxy that opens the run's
//!   iceoryx2 services like a worker and relays between them and zenoh.
//! - `RemoteBridge` (feature `multi-host`): on a worker host, a *mirror* of the run's services
//!   (created like a learner would, under a local run id) that local worker processes join
//!   unchanged.
//!
//! ## Data flow
//! learner → iceoryx2 → `LearnerBridge` → zenoh `envpg/v<N>/<run>/down` → `RemoteBridge` →
//! iceoryx2 mirror → workers → mirror → `RemoteBridge` → zenoh `…/up` → `LearnerBridge` →
//! iceoryx2 → learner.
//!
//! Remote workers get global ids `base + local id`, with a distinct `base` per joining host,
//! so the learner's assignment and determinism guarantees hold whatever joins: the result
//! depends only on the seed. A host speaking another protocol version is refused at join with
//! a message naming both versions; the versioned key expressions keep it from ever reading
//! or writing the run's messages.
//!
//! The default build has only [`wire`]; an episode crosses it like this:
//!
//! ```
//! use envpg_bridge::wire::{self, EpisodeMsg, Step, Up};
//!
//! let episode = Up::Episode(EpisodeMsg {
//!     worker_id: 1003, // global id: host base 1000 + local worker 3
//!     k: 5,
//!     episode: (0, 17),
//!     seq: 42,
//!     capped: false,
//!     zeta_dim: 2,
//!     steps: vec![
//!         Step { s: 0, a: 1, s2: 4, cost: 0.25, zeta: vec![0.5, 0.75] },
//!         Step { s: 4, a: 0, s2: 9, cost: 1.5, zeta: vec![0.5, 0.75] },
//!     ],
//! });
//! let bytes = wire::encode("episode", &episode)?;
//! assert_eq!(wire::decode::<Up>("episode", &bytes)?, episode);
//! // A message cut short on the way is refused, not half-read.
//! assert!(wire::decode::<Up>("episode", &bytes[..bytes.len() - 1]).is_err());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod wire;

#[cfg(feature = "multi-host")]
mod learner_side;
#[cfg(feature = "multi-host")]
mod remote_side;
#[cfg(feature = "multi-host")]
mod session;

#[cfg(feature = "multi-host")]
pub use learner_side::{LearnerBridge, LearnerBridgeConfig};
#[cfg(feature = "multi-host")]
pub use remote_side::{Joined, RemoteBridge, RemoteConfig};

/// Why the bridge failed.
#[derive(Debug, thiserror::Error)]
pub enum BridgeError {
    /// A message could not be encoded or decoded.
    #[error("bridge message {what}: {reason}")]
    Codec {
        /// Which message.
        what: &'static str,
        /// The postcard error.
        reason: String,
    },
    /// The peer speaks another protocol version.
    #[error("protocol mismatch: the learner host speaks envpg protocol v{learner}, this host v{remote}")]
    Version {
        /// The learner host's version.
        learner: u32,
        /// This (remote) host's version.
        remote: u32,
    },
    /// zenoh failed (session, publisher, subscriber, query).
    #[error("zenoh {what}: {reason}")]
    Zenoh {
        /// The operation.
        what: &'static str,
        /// zenoh's error.
        reason: String,
    },
    /// No learner answered the join request in time.
    #[error("no learner answered at {endpoint} within {seconds:.0} s (is `envpg-launch --listen {endpoint}` running?)")]
    NoLearner {
        /// Where we looked.
        endpoint: String,
        /// How long.
        seconds: f64,
    },
    /// The learner refused the join.
    #[error("the learner refused this host: {0}")]
    Refused(String),
    /// The local iceoryx2 side failed.
    #[error(transparent)]
    Transport(#[from] envpg_transport::TransportError),
}
