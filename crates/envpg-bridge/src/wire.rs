//! The messages of the bridge, as postcard bytes.
//!
//! Run messages travel on two versioned key expressions, [`down_key`] and [`up_key`]; a host of
//! another protocol version uses other keys and never sees them. The join exchange is the one
//! place both versions meet: [`JoinRequest`] and [`JoinReply`] start with the protocol version,
//! which [`peek_version`] reads before anything else is decoded.

use envpg_protocol::{
    EpisodeHeader, EpisodeId, Hello, MAX_ZETA, PROTOCOL_VERSION, TaskHeader, WeightsHeader, read_step, step_words,
    write_step,
};
use serde::{Deserialize, Serialize};

use crate::BridgeError;

/// Where a learner host answers join requests.
pub const JOIN_KEY: &str = "envpg/join";

/// Learner → remote hosts, for run `run_id`.
pub fn down_key(run_id: &str) -> String {
    format!("envpg/v{PROTOCOL_VERSION}/{run_id}/down")
}

/// Remote hosts → learner, for run `run_id`.
pub fn up_key(run_id: &str) -> String {
    format!("envpg/v{PROTOCOL_VERSION}/{run_id}/up")
}

/// Where the learner host answers "latest run info and weights" (a remote host resyncing
/// after its link came back).
pub fn latest_key(run_id: &str) -> String {
    format!("envpg/v{PROTOCOL_VERSION}/{run_id}/latest")
}

/// A remote host asks to join.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct JoinRequest {
    /// Its protocol version (first: readable by any version).
    pub protocol: u32,
    /// Its name, for logs.
    pub host: String,
    /// Worker processes it will run.
    pub workers: u32,
}

/// The learner host's answer.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct JoinReply {
    /// The learner's protocol version (first: readable by any version).
    pub protocol: u32,
    /// The run id (key expressions).
    pub run_id: String,
    /// The run's description for worker processes (the launcher's `run.json`, as JSON).
    pub run: String,
    /// Global id of this host's worker 0.
    pub id_base: u32,
    /// Link sizes the mirror must use.
    pub n_params: u32,
    /// Records per episode at most.
    pub episode_cap: u32,
    /// Episodes per iteration.
    pub episodes_per_iteration: u32,
    /// Dimension of ζ.
    pub zeta_dim: u32,
}

/// Run info.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Info {
    /// Dimension of ζ.
    pub zeta_dim: u32,
    /// The run has ended.
    pub finished: bool,
}

/// θ_k, ζ_k, α_k.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Weights {
    /// Iteration.
    pub k: u64,
    /// α_k.
    pub alpha: f64,
    /// ζ_k.
    pub zeta: Vec<f64>,
    /// Actor parameters.
    pub params: Vec<f32>,
}

/// Episodes of iteration k for one (global) worker.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Tasks {
    /// Global worker id.
    pub worker_id: u32,
    /// Its incarnation.
    pub incarnation: u64,
    /// Iteration.
    pub k: u64,
    /// (kind, index) of each episode.
    pub episodes: Vec<(u32, u32)>,
}

/// A hello of a (global) worker.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct HelloMsg {
    /// The worker's protocol version.
    pub protocol: u32,
    /// Kind (`envpg_protocol::hello_kind`).
    pub kind: u32,
    /// Global worker id.
    pub worker_id: u32,
    /// Its process id (on its host).
    pub pid: u32,
    /// Incarnation.
    pub incarnation: u64,
    /// Kind-specific detail.
    pub detail: u64,
}

/// One step of an episode.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Step {
    /// s_t.
    pub s: u32,
    /// a_t.
    pub a: u32,
    /// s_{t+1}.
    pub s2: u32,
    /// c_t.
    pub cost: f32,
    /// ζ_pert (ζ-dimension entries only).
    pub zeta: Vec<f32>,
}

/// One episode of a (global) worker.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EpisodeMsg {
    /// Global worker id.
    pub worker_id: u32,
    /// Iteration.
    pub k: u64,
    /// (kind, index).
    pub episode: (u32, u32),
    /// The worker's message sequence number.
    pub seq: u64,
    /// Hit the length cap.
    pub capped: bool,
    /// Dimension of ζ.
    pub zeta_dim: u32,
    /// The steps.
    pub steps: Vec<Step>,
}

/// Learner → remote hosts.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Down {
    /// Run info (sent at start, on change, and on request).
    Info(Info),
    /// Weights of iteration k.
    Weights(Weights),
    /// A task.
    Tasks(Tasks),
}

/// Remote hosts → learner.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Up {
    /// A worker's hello.
    Hello(HelloMsg),
    /// A finished episode.
    Episode(EpisodeMsg),
}

/// Encodes a message.
pub fn encode<T: Serialize>(what: &'static str, msg: &T) -> Result<Vec<u8>, BridgeError> {
    postcard::to_allocvec(msg).map_err(|e| BridgeError::Codec { what, reason: e.to_string() })
}

/// Decodes a message.
pub fn decode<'a, T: Deserialize<'a>>(what: &'static str, bytes: &'a [u8]) -> Result<T, BridgeError> {
    postcard::from_bytes(bytes).map_err(|e| BridgeError::Codec { what, reason: e.to_string() })
}

/// The protocol version at the start of a join message, whatever version wrote it.
pub fn peek_version(bytes: &[u8]) -> Result<u32, BridgeError> {
    postcard::take_from_bytes::<u32>(bytes)
        .map(|(v, _)| v)
        .map_err(|e| BridgeError::Codec { what: "join version", reason: e.to_string() })
}

impl Weights {
    /// From an iceoryx2 weights message.
    pub fn from_parts(h: &WeightsHeader, params: &[f32]) -> Self {
        let d = (h.zeta_dim as usize).min(MAX_ZETA);
        Self { k: h.k, alpha: h.alpha, zeta: h.zeta[..d].to_vec(), params: params.to_vec() }
    }
}

impl Tasks {
    /// From an iceoryx2 task message.
    pub fn from_parts(h: &TaskHeader, ids: &[EpisodeId]) -> Self {
        Self {
            worker_id: h.worker_id,
            incarnation: h.incarnation,
            k: h.k,
            episodes: ids.iter().map(|e| (e.kind, e.index)).collect(),
        }
    }

    /// The episode ids.
    pub fn ids(&self) -> Vec<EpisodeId> {
        self.episodes.iter().map(|&(kind, index)| EpisodeId { kind, index }).collect()
    }
}

impl HelloMsg {
    /// From an iceoryx2 hello, re-addressed to global worker id `worker_id`.
    pub fn from_hello(h: &Hello, worker_id: u32) -> Self {
        Self { protocol: h.protocol, kind: h.kind, worker_id, pid: h.pid, incarnation: h.incarnation, detail: h.detail }
    }

    /// The iceoryx2 hello (magic and run id are filled in by the sender).
    pub fn to_hello(&self) -> Hello {
        Hello {
            magic: envpg_protocol::MAGIC,
            protocol: self.protocol,
            kind: self.kind,
            worker_id: self.worker_id,
            pid: self.pid,
            incarnation: self.incarnation,
            run_id: [0; envpg_protocol::RUN_ID_LEN],
            detail: self.detail,
        }
    }
}

impl EpisodeMsg {
    /// From an iceoryx2 episode message, re-addressed to global worker id `worker_id`.
    pub fn from_parts(h: &EpisodeHeader, words: &[u32], worker_id: u32) -> Self {
        let d = (h.zeta_dim as usize).min(MAX_ZETA);
        Self {
            worker_id,
            k: h.k,
            episode: (h.episode.kind, h.episode.index),
            seq: h.seq,
            capped: h.capped != 0,
            zeta_dim: h.zeta_dim,
            steps: words
                .chunks_exact(step_words(d))
                .map(|rec| {
                    let (r, zeta) = read_step(rec);
                    Step { s: r.s, a: r.a, s2: r.s2, cost: r.cost, zeta: zeta.collect() }
                })
                .collect(),
        }
    }

    /// The iceoryx2 header (run id filled in by the sender) and payload words.
    pub fn to_parts(&self) -> Result<(EpisodeHeader, Vec<u32>), BridgeError> {
        let bad = |reason: String| BridgeError::Codec { what: "episode", reason };
        let d = self.zeta_dim as usize;
        if d > MAX_ZETA {
            return Err(bad(format!("ζ dimension {} exceeds {MAX_ZETA}", self.zeta_dim)));
        }
        let w = step_words(d);
        let mut words = vec![0u32; self.steps.len() * w];
        for (st, out) in self.steps.iter().zip(words.chunks_exact_mut(w)) {
            if st.zeta.len() != d {
                return Err(bad(format!("a step carries {} ζ entries, expected {}", st.zeta.len(), self.zeta_dim)));
            }
            let step = envpg_protocol::Step { s: st.s, a: st.a, s2: st.s2, cost: st.cost };
            write_step(out, step, &st.zeta);
        }
        let header = EpisodeHeader {
            protocol: PROTOCOL_VERSION,
            worker_id: self.worker_id,
            run_id: [0; envpg_protocol::RUN_ID_LEN],
            k: self.k,
            episode: EpisodeId { kind: self.episode.0, index: self.episode.1 },
            seq: self.seq,
            len: self.steps.len() as u32,
            capped: u32::from(self.capped),
            zeta_dim: self.zeta_dim,
            _pad: 0,
        };
        Ok((header, words))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn episodes_round_trip_through_the_wire_with_only_the_used_zeta_entries() {
        let mut words = vec![0u32; 2 * step_words(4)];
        for rec in words.chunks_exact_mut(step_words(4)) {
            write_step(rec, envpg_protocol::Step { s: 3, a: 1, s2: 7, cost: 0.5 }, &[1.0, 2.0, 3.0, 4.0]);
        }
        let h = EpisodeHeader {
            protocol: PROTOCOL_VERSION,
            worker_id: 2,
            run_id: [1; envpg_protocol::RUN_ID_LEN],
            k: 9,
            episode: EpisodeId { kind: 1, index: 4 },
            seq: 11,
            len: 2,
            capped: 1,
            zeta_dim: 4,
            _pad: 0,
        };
        let msg = Up::Episode(EpisodeMsg::from_parts(&h, &words, 1002));
        let bytes = encode("episode", &msg).unwrap();
        // A step is ~20 bytes on the wire.
        assert!(bytes.len() < 2 * 40, "{} bytes", bytes.len());
        let Up::Episode(back) = decode::<Up>("episode", &bytes).unwrap() else { panic!("not an episode") };
        let (h2, recs) = back.to_parts().unwrap();
        assert_eq!((h2.worker_id, h2.k, h2.episode, h2.seq, h2.len, h2.capped), (1002, 9, h.episode, 11, 2, 1));
        assert_eq!(recs, words);
    }

    #[test]
    fn malformed_messages_are_errors_not_panics() {
        assert!(decode::<Up>("up", &[0xff, 0xff, 0xff]).is_err());
        let bad = EpisodeMsg {
            worker_id: 0,
            k: 0,
            episode: (0, 0),
            seq: 0,
            capped: false,
            zeta_dim: 3,
            steps: vec![Step { s: 0, a: 0, s2: 0, cost: 0.0, zeta: vec![1.0] }],
        };
        assert!(bad.to_parts().is_err());
        let huge = EpisodeMsg { zeta_dim: 1000, steps: vec![], ..bad };
        assert!(huge.to_parts().is_err());
    }

    proptest::proptest! {
        /// Whatever bytes a peer sends — random, or a real message cut short or with bytes
        /// flipped — decoding is an error or a message, never a panic, and a decoded episode
        /// converts or is refused.
        #[test]
        fn any_bytes_decode_or_are_refused_never_panic(
            noise in proptest::collection::vec(proptest::num::u8::ANY, 0..256),
            cut in 0usize..200,
            flips in proptest::collection::vec((0usize..200, proptest::num::u8::ANY), 0..8),
        ) {
            let real = encode("up", &Up::Episode(EpisodeMsg {
                worker_id: 1001,
                k: 7,
                episode: (0, 3),
                seq: 2,
                capped: false,
                zeta_dim: 2,
                steps: vec![Step { s: 1, a: 2, s2: 3, cost: 0.5, zeta: vec![0.1, 0.2] }; 4],
            })).unwrap();
            let mut mutated = real[..cut.min(real.len())].to_vec();
            for (at, byte) in flips {
                if let Some(b) = mutated.get_mut(at) {
                    *b ^= byte;
                }
            }
            for bytes in [&noise, &mutated] {
                if let Ok(Up::Episode(e)) = decode::<Up>("up", bytes) {
                    let _ = e.to_parts();
                }
                let _ = decode::<Down>("down", bytes);
                let _ = decode::<JoinRequest>("join", bytes);
                let _ = decode::<JoinReply>("join", bytes);
                let _ = peek_version(bytes);
            }
        }
    }

    #[test]
    fn a_join_reply_of_any_version_shows_its_version_first() {
        let reply = JoinReply {
            protocol: 77,
            run_id: "r".into(),
            run: "{}".into(),
            id_base: 1000,
            n_params: 1,
            episode_cap: 2,
            episodes_per_iteration: 3,
            zeta_dim: 4,
        };
        assert_eq!(peek_version(&encode("join", &reply).unwrap()).unwrap(), 77);
        let req = JoinRequest { protocol: 5, host: "h".into(), workers: 2 };
        assert_eq!(peek_version(&encode("join", &req).unwrap()).unwrap(), 5);
    }

    #[test]
    fn weights_and_tasks_round_trip() {
        let mut h = WeightsHeader { k: 3, alpha: 0.5, zeta_dim: 2, ..Default::default() };
        h.zeta[..2].copy_from_slice(&[1.5, -2.0]);
        let w = Weights::from_parts(&h, &[1.0, 2.0, 3.0]);
        assert_eq!((w.zeta.as_slice(), w.params.len()), ([1.5, -2.0].as_slice(), 3));
        let d = Down::Weights(w);
        assert_eq!(decode::<Down>("down", &encode("down", &d).unwrap()).unwrap(), d);
        let th = TaskHeader { worker_id: 1001, incarnation: 2, k: 3, ..Default::default() };
        let t = Tasks::from_parts(&th, &[EpisodeId { kind: 0, index: 5 }]);
        assert_eq!(t.ids(), [EpisodeId { kind: 0, index: 5 }]);
    }
}
