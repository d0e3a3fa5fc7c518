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
//! [`TransportError`]s that say which port of which service failed. Before creating its node,
//! each end removes the shared memory of processes that died while creating it
//! ([`remove_unfinished_segments`]): iceoryx2 would otherwise wait for it without end.
//!
//! Data flow: learner `publish_weights` + `assign` → worker `latest_weights` + `take_tasks` →
//! rollouts → worker `publish_episode` → learner `receive_episodes`.
//!
//! ```
//! use std::time::Duration;
//! use envpg_protocol::{EpisodeHeader, PROTOCOL_VERSION, Step, read_step, run_id_bytes, step_words, write_step};
//! use envpg_transport::{LearnerEnd, LinkSizes, TransportError, WorkerEnd, local};
//!
//! let sizes = LinkSizes { max_workers: 1, n_params: 3, episode_cap: 4, episodes_per_iteration: 1 };
//! let learner = LearnerEnd::<local::Service>::create("doc-link", sizes)?;
//! learner.announce(1, false)?; // ζ has one coordinate; the run is on
//! learner.publish_weights(0, 1.0, &[0.5], &[0.1, 0.2, 0.3])?; // θ_0, ζ_0, α_0, kept for late joiners
//! // A worker thread joins, answers the weights with a one-step episode, and stays until the run ends.
//! let worker = std::thread::spawn(|| -> Result<(), TransportError> {
//!     let end = WorkerEnd::<local::Service>::open("doc-link", 0, PROTOCOL_VERSION, Duration::from_secs(5))?;
//!     let (w, theta) = loop { if let Some(latest) = end.latest_weights()? { break latest; } };
//!     assert_eq!((w.k, w.zeta[0], theta), (0, 0.5, vec![0.1, 0.2, 0.3]));
//!     let header = EpisodeHeader { protocol: PROTOCOL_VERSION, run_id: run_id_bytes("doc-link"), k: w.k, len: 1, zeta_dim: 1, ..Default::default() };
//!     let mut words = [0u32; step_words(1)]; // s, a, s', c and ζ_pert: 5 words
//!     write_step(&mut words, Step { s: 0, a: 1, s2: 2, cost: 2.5 }, &[0.5]);
//!     end.publish_episode(header, &words)?;
//!     while !end.run_finished()? {} // a publisher's samples go with it: stay until the run is over
//!     Ok(())
//! });
//! let mut got = Vec::new();
//! while got.is_empty() && !worker.is_finished() {
//!     learner.refresh(); // hands late joiners the run info and the latest weights
//!     learner.receive_episodes(|h, words| got.push((h.k, h.len, read_step(words).0.cost)))?;
//! }
//! learner.announce(1, true)?;
//! worker.join().unwrap()?;
//! assert_eq!(got, [(0, 1, 2.5)]);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod ends;
mod error;
mod unfinished;

pub use ends::{LearnerEnd, LinkSizes, WorkerEnd, quiet_iceoryx2_logs};
pub use error::TransportError;
pub use iceoryx2::prelude::{ipc, local};
pub use unfinished::{SETTLE, SHM_DIR, remove_unfinished_in, remove_unfinished_segments};
