//! # envpg-transport
//!
//! The two ends of envpg's iceoryx2 link, generic over the iceoryx2 service kind: `ipc` (shared
//! memory between processes) or `local` (threads of one process — the in-process fallback).
//!
//! - [`LearnerEnd`] creates the run's services and owns the publishing side of run info,
//!   weights and tasks and the receiving side of hellos and episodes.
//! - [`WorkerEnd`] opens them from the other side.
//!
//! Each end also holds a *listener* woken by the other side's *notifier* once per message, so
//! both sides block in a WaitSet instead of spinning. Operations return
//! [`TransportError`]s that say which port of which service failed.
//!
//! Data flow: learner `publish_weights` + `assign` → worker `latest_weights` + `take_tasks` →
//! rollouts → worker `publish_episode` → learner `receive_episodes`.

mod ends;
mod error;

pub use ends::{LearnerEnd, LinkSizes, WorkerEnd, quiet_iceoryx2_logs};
pub use error::TransportError;
pub use iceoryx2::prelude::{ipc, local};
