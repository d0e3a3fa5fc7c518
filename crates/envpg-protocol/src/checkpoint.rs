//! [`Checkpoint`]: the learner's saved state, and the file that holds it.
//!
//! File layout (little-endian): the 8 bytes `envpgCKP`, the format version (u32), the CRC-32
//! of the payload (u32), the payload's length (u64), then the payload: the [`Checkpoint`] in
//! postcard. A truncated, bit-flipped or foreign file is refused with the reason before any
//! field is trusted; a sound file is then checked against the run resuming it
//! ([`Checkpoint::check_for`]).

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::PROTOCOL_VERSION;

const FILE_MAGIC: [u8; 8] = *b"envpgCKP";
/// Version of the file framing (not of the protocol, which the payload carries).
const FILE_FORMAT: u32 = 1;
const HEADER_LEN: usize = 24;

/// The learner's saved state, enough to continue a run bitwise identically.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Checkpoint {
    /// [`PROTOCOL_VERSION`] of the writer.
    pub protocol: u32,
    /// The run it belongs to.
    pub run_id: String,
    /// Iterations completed when it was written.
    pub k: u64,
    /// The run specification, as JSON (canonical instance with its environment, seed, settings).
    pub spec_json: String,
    /// The learner's state, postcard-encoded (parameters, optimiser moments, ζ, α, k,
    /// counters): binary so every float comes back bit for bit.
    pub learner: Vec<u8>,
    /// The recorder's history so far, as JSON.
    pub history_json: String,
    /// Transitions consumed so far.
    pub transitions: u64,
    /// Capped episodes so far.
    pub capped: u64,
    /// Wall-clock seconds spent before this checkpoint.
    pub seconds: f64,
}

/// Why a checkpoint could not be read, or does not belong to the run resuming it.
#[derive(Debug, thiserror::Error)]
pub enum CheckpointError {
    /// File system error.
    #[error("checkpoint {path}: {err}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The error.
        err: std::io::Error,
    },
    /// Not a checkpoint, or a corrupt one.
    #[error("checkpoint {path} is not usable: {reason}")]
    Format {
        /// The file.
        path: PathBuf,
        /// What failed.
        reason: String,
    },
    /// Written by another protocol version.
    #[error("checkpoint {path} was written by protocol version {found}, this build speaks version {expected}")]
    Version {
        /// The file.
        path: PathBuf,
        /// Version in the file.
        found: u32,
        /// Our version.
        expected: u32,
    },
    /// A sound checkpoint of another run, or of the same run with other settings.
    #[error("checkpoint {path} does not belong to this run: {reason}")]
    Mismatch {
        /// The file.
        path: PathBuf,
        /// What differs.
        reason: String,
    },
}

/// An `io::Write` that only hashes and counts what it is given.
#[derive(Default)]
struct CrcWriter {
    crc: crc32fast::Hasher,
    len: usize,
}

impl std::io::Write for CrcWriter {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.crc.update(buf);
        self.len += buf.len();
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl Checkpoint {
    /// The framed file contents.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::new();
        self.write_to(&mut out).expect("writing to memory cannot fail");
        out
    }

    /// Writes the framed file contents to `w`, streaming the payload: a checkpoint of a large
    /// run is tens of MB, and the learner's peak memory would otherwise be this copy of it. The
    /// payload is serialised twice — once into its CRC and length, once into `w` — rather than
    /// held.
    pub fn write_to(&self, w: &mut dyn std::io::Write) -> std::io::Result<()> {
        let invalid = |e: postcard::Error| std::io::Error::new(std::io::ErrorKind::InvalidData, e.to_string());
        let sum = postcard::to_io(self, CrcWriter::default()).map_err(invalid)?;
        let (crc, len) = (sum.crc.finalize(), sum.len);
        w.write_all(&FILE_MAGIC)?;
        w.write_all(&FILE_FORMAT.to_le_bytes())?;
        w.write_all(&crc.to_le_bytes())?;
        w.write_all(&(len as u64).to_le_bytes())?;
        postcard::to_io(self, w).map_err(invalid)?;
        Ok(())
    }

    /// Parses framed file contents (`path` names the file in errors).
    pub fn from_bytes(bytes: &[u8], path: &Path) -> Result<Self, CheckpointError> {
        let bad = |reason: String| CheckpointError::Format { path: path.to_owned(), reason };
        if bytes.len() < HEADER_LEN || bytes[..8] != FILE_MAGIC {
            return Err(bad(if bytes.starts_with(&FILE_MAGIC) || FILE_MAGIC.starts_with(bytes) {
                format!("truncated: {} bytes, shorter than its header", bytes.len())
            } else {
                "not an envpg checkpoint (no envpgCKP header)".into()
            }));
        }
        let word = |at: usize| u32::from_le_bytes(bytes[at..at + 4].try_into().expect("4 bytes"));
        let format = word(8);
        if format != FILE_FORMAT {
            return Err(bad(format!("file format {format}, this build reads format {FILE_FORMAT}")));
        }
        let crc = word(12);
        let len = u64::from_le_bytes(bytes[16..24].try_into().expect("8 bytes"));
        let payload = &bytes[HEADER_LEN..];
        if payload.len() as u64 != len {
            return Err(bad(format!(
                "truncated or padded: the header promises {len} bytes of state, the file holds {}",
                payload.len()
            )));
        }
        if crc32fast::hash(payload) != crc {
            return Err(bad("checksum mismatch: the file is corrupt".into()));
        }
        let c: Checkpoint = postcard::from_bytes(payload).map_err(|e| bad(format!("undecodable state: {e}")))?;
        if c.protocol != PROTOCOL_VERSION {
            return Err(CheckpointError::Version {
                path: path.to_owned(),
                found: c.protocol,
                expected: PROTOCOL_VERSION,
            });
        }
        Ok(c)
    }

    /// Reads and checks a checkpoint file.
    pub fn load(path: &Path) -> Result<Self, CheckpointError> {
        let bytes = std::fs::read(path).map_err(|err| CheckpointError::Io { path: path.to_owned(), err })?;
        Self::from_bytes(&bytes, path)
    }

    /// Checks that this checkpoint belongs to run `run_id` with specification `spec_json` (the
    /// run directory's), naming the first setting that differs.
    pub fn check_for(&self, path: &Path, run_id: &str, spec_json: &str) -> Result<(), CheckpointError> {
        let mismatch = |reason: String| CheckpointError::Mismatch { path: path.to_owned(), reason };
        if self.run_id != run_id {
            return Err(mismatch(format!("it was written by run {}, this is run {run_id}", self.run_id)));
        }
        if self.spec_json == spec_json {
            return Ok(());
        }
        let parse = |t: &str| serde_json::from_str::<serde_json::Value>(t).unwrap_or(serde_json::Value::Null);
        let (ours, theirs) = (parse(&self.spec_json), parse(spec_json));
        Err(mismatch(match first_difference(&ours, &theirs, String::new()) {
            Some((at, a, b)) => format!("its settings differ at `{at}`: {a} in the checkpoint, {b} in the run"),
            None => "its run description differs from the run's".into(),
        }))
    }
}

/// The first place two JSON values differ: (path, value in `a`, value in `b`).
fn first_difference(a: &serde_json::Value, b: &serde_json::Value, at: String) -> Option<(String, String, String)> {
    use serde_json::Value;
    let join = |k: &str| if at.is_empty() { k.to_owned() } else { format!("{at}.{k}") };
    let short = |v: Option<&Value>| {
        let t = v.map_or("nothing".to_owned(), Value::to_string);
        if t.len() > 60 { format!("{}…", &t[..t.floor_char_boundary(60)]) } else { t }
    };
    match (a, b) {
        (Value::Object(x), Value::Object(y)) => {
            let keys: std::collections::BTreeSet<&String> = x.keys().chain(y.keys()).collect();
            keys.into_iter().find_map(|k| match (x.get(k), y.get(k)) {
                (Some(p), Some(q)) => first_difference(p, q, join(k)),
                (p, q) => Some((join(k), short(p), short(q))),
            })
        }
        (Value::Array(x), Value::Array(y)) if x.len() == y.len() => {
            x.iter().zip(y).enumerate().find_map(|(i, (p, q))| first_difference(p, q, format!("{at}[{i}]")))
        }
        _ if a == b => None,
        _ => Some((at, short(Some(a)), short(Some(b)))),
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    fn sample() -> Checkpoint {
        Checkpoint {
            protocol: PROTOCOL_VERSION,
            run_id: "0123456789abcdef".into(),
            k: 7,
            spec_json: r#"{"seed":1,"config":{"iterations":200}}"#.into(),
            learner: (0..200u8).collect(),
            history_json: "[]".into(),
            transitions: 9,
            capped: 1,
            seconds: 0.5,
        }
    }

    fn path() -> PathBuf {
        PathBuf::from("run/checkpoint.bin")
    }

    #[test]
    fn round_trips_and_names_the_file_in_errors() {
        let c = sample();
        assert_eq!(Checkpoint::from_bytes(&c.to_bytes(), &path()).unwrap(), c);
        let e = Checkpoint::from_bytes(b"{\"k\": 1}", &path()).unwrap_err().to_string();
        assert!(e.contains("run/checkpoint.bin") && e.contains("not an envpg checkpoint"), "{e}");
    }

    #[test]
    fn every_truncation_is_refused() {
        let bytes = sample().to_bytes();
        for n in 0..bytes.len() {
            let e = Checkpoint::from_bytes(&bytes[..n], &path()).unwrap_err();
            assert!(matches!(e, CheckpointError::Format { .. }), "{n} bytes: {e}");
        }
    }

    #[test]
    fn every_single_bit_flip_is_refused() {
        let bytes = sample().to_bytes();
        for i in 0..bytes.len() * 8 {
            let mut b = bytes.clone();
            b[i / 8] ^= 1 << (i % 8);
            assert!(Checkpoint::from_bytes(&b, &path()).is_err(), "bit {i} flipped went unnoticed");
        }
    }

    #[test]
    fn other_protocol_versions_are_refused_naming_both() {
        let c = Checkpoint { protocol: PROTOCOL_VERSION + 1, ..sample() };
        let e = Checkpoint::from_bytes(&c.to_bytes(), &path()).unwrap_err().to_string();
        assert!(
            e.contains(&format!("version {}", PROTOCOL_VERSION + 1))
                && e.contains(&format!("version {PROTOCOL_VERSION}")),
            "{e}"
        );
    }

    #[test]
    fn a_foreign_run_or_other_settings_are_named() {
        let c = sample();
        c.check_for(&path(), &c.run_id, &c.spec_json).unwrap();
        let e = c.check_for(&path(), "fedcba9876543210", &c.spec_json).unwrap_err().to_string();
        assert!(e.contains("fedcba9876543210") && e.contains("0123456789abcdef"), "{e}");
        let e = c.check_for(&path(), &c.run_id, r#"{"seed":1,"config":{"iterations":300}}"#).unwrap_err().to_string();
        assert!(e.contains("`config.iterations`: 200 in the checkpoint, 300 in the run"), "{e}");
        let e = c.check_for(&path(), &c.run_id, r#"{"seed":1}"#).unwrap_err().to_string();
        assert!(e.contains("`config`") && e.contains("nothing in the run"), "{e}");
    }

    proptest! {
        #[test]
        fn random_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
            let _ = Checkpoint::from_bytes(&bytes, &path());
        }

        #[test]
        fn random_overwrites_of_a_real_checkpoint_are_refused(
            at in 0usize..10_000,
            junk in proptest::collection::vec(any::<u8>(), 1..16),
        ) {
            let mut b = sample().to_bytes();
            let at = at % b.len();
            let mut changed = false;
            for (i, &x) in junk.iter().enumerate() {
                if let Some(slot) = b.get_mut(at + i) {
                    changed |= *slot != x;
                    *slot = x;
                }
            }
            prop_assume!(changed);
            prop_assert!(Checkpoint::from_bytes(&b, &path()).is_err());
        }
    }
}
