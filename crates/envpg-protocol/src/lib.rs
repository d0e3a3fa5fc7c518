//! # envpg-protocol
//!
//! Every type that crosses a process boundary, and nothing else. The distributed run is a
//! learner and rollout workers talking over iceoryx2 publish–subscribe services whose names all
//! start with `envpg/<run id>/`:
//!
//! | service | direction | header | payload |
//! |---|---|---|---|
//! | [`ServiceNames::run_info`] | learner → all | — | [`RunInfo`] (history 1) |
//! | [`ServiceNames::hello`] | workers → learner | — | [`Hello`] (join, heartbeat, leave) |
//! | [`ServiceNames::weights`] | learner → workers | [`WeightsHeader`] | `[f32]` actor θ_k (history 1) |
//! | [`ServiceNames::tasks`] | learner → workers | [`TaskHeader`] | `[EpisodeId]` |
//! | [`ServiceNames::episodes`] | workers → learner | [`EpisodeHeader`] | `[u32]`: per step [`step_words`]`(d)` words ([`write_step`]) |
//!
//! plus event services ([`ServiceNames::learner_wakeup`], [`ServiceNames::worker_wakeup`]) that
//! wake the other side's WaitSet once per message, never per record.
//!
//! [`RunInfo`] and [`Hello`] have type names that never change, so peers of any version can
//! still exchange them and refuse each other with a message naming both versions. Everything
//! else carries the version in its type name and service name: a peer of another version
//! cannot even open those services. Every header repeats the version and the run id.
//!
//! [`Checkpoint`] is the learner's saved state: postcard inside a framed file (magic, format
//! version, length, CRC-32), written atomically and checked against the run that resumes it.
//!
//! ```
//! use std::path::Path;
//! use envpg_protocol::{Checkpoint, CheckpointError, PROTOCOL_VERSION, run_id_bytes, run_id_str};
//!
//! // Run ids travel as fixed, zero-padded bytes in every header.
//! assert_eq!(run_id_str(&run_id_bytes("run-42")), "run-42");
//!
//! let spec = r#"{"seed":1,"config":{"iterations":200}}"#;
//! let ckpt = Checkpoint {
//!     protocol: PROTOCOL_VERSION,
//!     run_id: "run-42".into(),
//!     k: 7,
//!     spec_json: spec.into(),
//!     learner: vec![1, 2, 3],
//!     history_json: "[]".into(),
//!     transitions: 900,
//!     capped: 0,
//!     seconds: 0.5,
//! };
//! let path = Path::new("run-42/checkpoint.bin"); // only names the file in errors
//! let mut bytes = ckpt.to_bytes();
//! let back = Checkpoint::from_bytes(&bytes, path)?;
//! assert_eq!(back, ckpt);
//! back.check_for(path, "run-42", spec)?; // the run it belongs to accepts it, another refuses it
//! assert!(matches!(back.check_for(path, "run-43", spec), Err(CheckpointError::Mismatch { .. })));
//! *bytes.last_mut().unwrap() ^= 1; // one flipped bit: the CRC-32 refuses the file
//! assert!(matches!(Checkpoint::from_bytes(&bytes, path), Err(CheckpointError::Format { .. })));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod checkpoint;

pub use checkpoint::{Checkpoint, CheckpointError};
use iceoryx2::prelude::*;

/// Version of this protocol. Bump on any change to a type below or to the run description
/// peers exchange (version 2: the run names its environment and carries its instance; 3: the
/// run settings and the checkpointed learner state carry the policy lag).
pub const PROTOCOL_VERSION: u32 = 3;

/// Marks envpg messages in the version-agnostic types (a fixed tag, not a version).
pub const MAGIC: u64 = 0x656e_7670_675f_7631; // "envpg_v1"

/// Largest ζ dimension carried in headers and records (32 points in the plane).
pub const MAX_ZETA: usize = 64;

/// Bytes of a run id.
pub const RUN_ID_LEN: usize = 16;

/// A run id as fixed bytes (ASCII, zero-padded).
pub type RunId = [u8; RUN_ID_LEN];

/// Converts a run id string (at most [`RUN_ID_LEN`] ASCII bytes) to its fixed form.
pub fn run_id_bytes(id: &str) -> RunId {
    let mut out = [0u8; RUN_ID_LEN];
    for (o, b) in out.iter_mut().zip(id.bytes()) {
        *o = b;
    }
    out
}

/// The string form of a fixed run id.
pub fn run_id_str(id: &RunId) -> String {
    String::from_utf8_lossy(&id[..id.iter().position(|&b| b == 0).unwrap_or(RUN_ID_LEN)]).into_owned()
}

/// What the learner announces about the run (version-agnostic layout).
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[repr(C)]
#[type_name("envpg.RunInfo")]
pub struct RunInfo {
    /// [`MAGIC`].
    pub magic: u64,
    /// The learner's [`PROTOCOL_VERSION`].
    pub protocol: u32,
    /// Dimension of ζ.
    pub zeta_dim: u32,
    /// Number of actor parameters in a weights message.
    pub n_params: u32,
    /// Episode length cap (records per episode message at most).
    pub episode_cap: u32,
    /// Run id.
    pub run_id: RunId,
    /// Non-zero once the run has ended: workers should leave.
    pub finished: u32,
    /// Padding.
    pub _pad: u32,
}

/// Kinds of [`Hello`] message.
pub mod hello_kind {
    /// A worker joins.
    pub const JOIN: u32 = 0;
    /// A worker is alive.
    pub const HEARTBEAT: u32 = 1;
    /// A worker leaves cleanly.
    pub const LEAVE: u32 = 2;
    /// A worker refuses the run (protocol mismatch); `detail` holds the learner's version.
    pub const REFUSE: u32 = 3;
}

/// A worker's join / heartbeat / leave message (version-agnostic layout).
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[repr(C)]
#[type_name("envpg.Hello")]
pub struct Hello {
    /// [`MAGIC`].
    pub magic: u64,
    /// The worker's [`PROTOCOL_VERSION`].
    pub protocol: u32,
    /// See [`hello_kind`].
    pub kind: u32,
    /// Worker id (slot); a replacement reuses its predecessor's id.
    pub worker_id: u32,
    /// Operating-system process id.
    pub pid: u32,
    /// Incarnation: distinguishes a replacement from the worker it replaces.
    pub incarnation: u64,
    /// Run id the worker believes it belongs to.
    pub run_id: RunId,
    /// Kind-specific detail.
    pub detail: u64,
}

/// Header of a weights broadcast: everything a worker needs for iteration k besides θ_k.
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[repr(C)]
#[type_name("envpg.v2.WeightsHeader")]
pub struct WeightsHeader {
    /// [`PROTOCOL_VERSION`].
    pub protocol: u32,
    /// Dimension of ζ used in `zeta`.
    pub zeta_dim: u32,
    /// Run id.
    pub run_id: RunId,
    /// Iteration k.
    pub k: u64,
    /// Number of parameters in the payload.
    pub n_params: u64,
    /// α_k.
    pub alpha: f64,
    /// ζ_k (first `zeta_dim` entries).
    pub zeta: [f64; MAX_ZETA],
}

impl Default for WeightsHeader {
    fn default() -> Self {
        Self {
            protocol: PROTOCOL_VERSION,
            zeta_dim: 0,
            run_id: [0; RUN_ID_LEN],
            k: 0,
            n_params: 0,
            alpha: 0.0,
            zeta: [0.0; MAX_ZETA],
        }
    }
}

/// Identifies one episode of an iteration.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, PartialOrd, Ord, ZeroCopySend)]
#[repr(C)]
#[type_name("envpg.v2.EpisodeId")]
pub struct EpisodeId {
    /// 0: on-policy, 1: exploration.
    pub kind: u32,
    /// Index within its kind.
    pub index: u32,
}

/// Header of a task message: episodes of iteration k assigned to one worker.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[repr(C)]
#[type_name("envpg.v2.TaskHeader")]
pub struct TaskHeader {
    /// [`PROTOCOL_VERSION`].
    pub protocol: u32,
    /// The worker the task is for.
    pub worker_id: u32,
    /// Run id.
    pub run_id: RunId,
    /// Iteration k.
    pub k: u64,
    /// Incarnation of the worker the task is for.
    pub incarnation: u64,
}

/// Header of one episode's transitions.
#[derive(Debug, Clone, Copy, Default, PartialEq, ZeroCopySend)]
#[repr(C)]
#[type_name("envpg.v2.EpisodeHeader")]
pub struct EpisodeHeader {
    /// [`PROTOCOL_VERSION`].
    pub protocol: u32,
    /// Worker that ran it.
    pub worker_id: u32,
    /// Run id.
    pub run_id: RunId,
    /// Iteration k.
    pub k: u64,
    /// Which episode.
    pub episode: EpisodeId,
    /// Per-worker sequence number of this message.
    pub seq: u64,
    /// Number of records (steps).
    pub len: u32,
    /// Non-zero if the episode hit the length cap.
    pub capped: u32,
    /// Dimension of ζ in the records.
    pub zeta_dim: u32,
    /// Padding.
    pub _pad: u32,
}

/// One step of an episode: (s, a, s', c). Its perturbed design ζ_pert travels beside it in an
/// episode message ([`write_step`], [`read_step`]).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Step {
    /// s_t.
    pub s: u32,
    /// a_t.
    pub a: u32,
    /// s_{t+1}.
    pub s2: u32,
    /// c_t.
    pub cost: f32,
}

/// Words (u32) per step of an episode message whose designs have `zeta_dim` coordinates: s,
/// a, s', the bits of the f32 cost, then the bits of the step's f32 ζ_pert — a message is
/// sized to the run's ζ, not to [`MAX_ZETA`] (56 bytes a step for ζ ∈ ℝ¹⁰).
pub const fn step_words(zeta_dim: usize) -> usize {
    4 + zeta_dim
}

/// Writes `step` and its ζ_pert into `out`, which holds [`step_words`]`(zeta.len())` words.
pub fn write_step(out: &mut [u32], step: Step, zeta: &[f32]) {
    debug_assert_eq!(out.len(), step_words(zeta.len()), "step record size");
    out[..4].copy_from_slice(&[step.s, step.a, step.s2, step.cost.to_bits()]);
    for (o, z) in out[4..].iter_mut().zip(zeta) {
        *o = z.to_bits();
    }
}

/// Reads a step and its ζ_pert back from the [`step_words`] words [`write_step`] wrote.
pub fn read_step(words: &[u32]) -> (Step, impl ExactSizeIterator<Item = f32> + '_) {
    let step = Step { s: words[0], a: words[1], s2: words[2], cost: f32::from_bits(words[3]) };
    (step, words[4..].iter().map(|&w| f32::from_bits(w)))
}

/// The names of a run's services.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ServiceNames {
    prefix: String,
}

impl ServiceNames {
    /// Names for run `run_id`.
    pub fn new(run_id: &str) -> Self {
        Self { prefix: format!("envpg/{run_id}") }
    }
    /// Run information (version-agnostic).
    pub fn run_info(&self) -> String {
        format!("{}/run-info", self.prefix)
    }
    /// Worker join/heartbeat/leave (version-agnostic).
    pub fn hello(&self) -> String {
        format!("{}/hello", self.prefix)
    }
    /// Weights broadcast.
    pub fn weights(&self) -> String {
        format!("{}/v{PROTOCOL_VERSION}/weights", self.prefix)
    }
    /// Task assignment.
    pub fn tasks(&self) -> String {
        format!("{}/v{PROTOCOL_VERSION}/tasks", self.prefix)
    }
    /// Episode transitions.
    pub fn episodes(&self) -> String {
        format!("{}/v{PROTOCOL_VERSION}/episodes", self.prefix)
    }
    /// Event that wakes the learner.
    pub fn learner_wakeup(&self) -> String {
        format!("{}/learner-wakeup", self.prefix)
    }
    /// Event that wakes the workers.
    pub fn worker_wakeup(&self) -> String {
        format!("{}/worker-wakeup", self.prefix)
    }
    /// The common prefix.
    pub fn prefix(&self) -> &str {
        &self.prefix
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn run_ids_round_trip_and_names_carry_run_and_version() {
        let id = run_id_bytes("a1b2c3");
        assert_eq!(run_id_str(&id), "a1b2c3");
        let n = ServiceNames::new("a1b2c3");
        assert_eq!(n.episodes(), format!("envpg/a1b2c3/v{PROTOCOL_VERSION}/episodes"));
        assert!(n.hello().starts_with("envpg/a1b2c3/"));
    }

    #[test]
    fn steps_round_trip_through_their_words_with_only_the_runs_zeta() {
        let step = Step { s: 3, a: 1, s2: 270, cost: -0.25 };
        let zeta = [1.5f32, f32::MIN_POSITIVE, -0.0];
        let mut words = vec![0u32; step_words(zeta.len())];
        assert_eq!(words.len(), 7);
        write_step(&mut words, step, &zeta);
        let (back, z) = read_step(&words);
        assert_eq!(back, step);
        let z: Vec<f32> = z.collect();
        assert_eq!(z.iter().map(|x| x.to_bits()).collect::<Vec<_>>(), zeta.map(f32::to_bits));
    }

    #[test]
    fn type_names_are_stable_and_versioned() {
        // SAFETY: type_name only returns a static string.
        unsafe {
            assert_eq!(RunInfo::type_name(), "envpg.RunInfo");
            assert_eq!(Hello::type_name(), "envpg.Hello");
            assert_eq!(EpisodeHeader::type_name(), "envpg.v2.EpisodeHeader");
        }
    }
}
