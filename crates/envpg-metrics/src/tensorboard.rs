//! [`EventWriter`]: TensorBoard event files, written without TensorFlow.
//!
//! An event file is a sequence of TFRecord frames — length (u64, little-endian), masked
//! CRC-32C of the length, the payload, masked CRC-32C of the payload — each payload a
//! `tensorflow.Event` protobuf message. The first event names the file version; each
//! iteration then writes one event whose summary holds that iteration's scalars
//! (`simple_value`). The messages are the few fields of TensorFlow's `event.proto` and
//! `summary.proto` that scalars need, derived with prost.

use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::{SystemTime, UNIX_EPOCH};

use prost::Message;

use crate::{MetricsError, io_err};

/// `tensorflow.Event` (the fields written here).
#[derive(Clone, PartialEq, prost::Message)]
pub struct Event {
    /// Seconds since the Unix epoch.
    #[prost(double, tag = "1")]
    pub wall_time: f64,
    /// The step (envpg's iteration k).
    #[prost(int64, tag = "2")]
    pub step: i64,
    /// Set in the first event of a file: `brain.Event:2`.
    #[prost(string, optional, tag = "3")]
    pub file_version: Option<String>,
    /// The scalars of one step.
    #[prost(message, optional, tag = "5")]
    pub summary: Option<Summary>,
    /// A (re)start of the run: TensorBoard drops points of earlier files at or after `step`.
    #[prost(message, optional, tag = "7")]
    pub session_log: Option<SessionLog>,
}

/// `tensorflow.Summary`.
#[derive(Clone, PartialEq, prost::Message)]
pub struct Summary {
    /// One value per tag.
    #[prost(message, repeated, tag = "1")]
    pub value: Vec<SummaryValue>,
}

/// `tensorflow.Summary.Value` (scalars only).
#[derive(Clone, PartialEq, prost::Message)]
pub struct SummaryValue {
    /// The tag (the chart's name).
    #[prost(string, tag = "1")]
    pub tag: String,
    /// The scalar.
    #[prost(float, optional, tag = "2")]
    pub simple_value: Option<f32>,
}

/// `tensorflow.SessionLog`.
#[derive(Clone, PartialEq, prost::Message)]
pub struct SessionLog {
    /// 1 = START.
    #[prost(int32, tag = "1")]
    pub status: i32,
}

/// The file version TensorBoard expects in the first event.
pub const FILE_VERSION: &str = "brain.Event:2";

const CASTAGNOLI: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISCSI);

/// TFRecord's masked CRC-32C.
pub fn masked_crc32c(bytes: &[u8]) -> u32 {
    let c = CASTAGNOLI.checksum(bytes);
    c.rotate_right(15).wrapping_add(0xa282_ead8)
}

/// One TFRecord frame around `payload`.
pub fn frame(payload: &[u8]) -> Vec<u8> {
    let len = (payload.len() as u64).to_le_bytes();
    let mut out = Vec::with_capacity(payload.len() + 16);
    out.extend_from_slice(&len);
    out.extend_from_slice(&masked_crc32c(&len).to_le_bytes());
    out.extend_from_slice(payload);
    out.extend_from_slice(&masked_crc32c(payload).to_le_bytes());
    out
}

/// Writes one TensorBoard event file.
#[derive(Debug)]
pub struct EventWriter {
    path: PathBuf,
    file: File,
}

fn now() -> f64 {
    SystemTime::now().duration_since(UNIX_EPOCH).map_or(0.0, |d| d.as_secs_f64())
}

impl EventWriter {
    /// Creates a new event file in `dir` (created if missing), named as TensorBoard expects
    /// (`events.out.tfevents.<seconds>.<host>.<pid>`), and writes the file-version event; a
    /// resumed run (`resume_from` = its first iteration) adds a restart marker at that step.
    pub fn create(dir: &Path, resume_from: Option<u64>) -> Result<Self, MetricsError> {
        std::fs::create_dir_all(dir).map_err(io_err(dir))?;
        let host = std::fs::read_to_string("/proc/sys/kernel/hostname")
            .map(|h| h.trim().to_owned())
            .ok()
            .filter(|h| !h.is_empty())
            .unwrap_or_else(|| "localhost".into());
        let t = now();
        // Two files of one directory sort in the order they were started.
        let path = dir.join(format!("events.out.tfevents.{:010}.{host}.{}", t as u64, std::process::id()));
        let file = File::create(&path).map_err(io_err(&path))?;
        let mut w = Self { path, file };
        w.write(&Event { wall_time: t, file_version: Some(FILE_VERSION.into()), ..Default::default() })?;
        if let Some(k) = resume_from {
            w.write(&Event {
                wall_time: t,
                step: k as i64,
                session_log: Some(SessionLog { status: 1 }),
                ..Default::default()
            })?;
        }
        Ok(w)
    }

    /// The event file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Writes the scalars of step `k` as one event and flushes it.
    pub fn scalars(&mut self, k: u64, scalars: &[(&str, f64)]) -> Result<(), MetricsError> {
        let value = scalars
            .iter()
            .map(|(tag, v)| SummaryValue { tag: (*tag).to_owned(), simple_value: Some(*v as f32) })
            .collect();
        self.write(&Event { wall_time: now(), step: k as i64, summary: Some(Summary { value }), ..Default::default() })
    }

    fn write(&mut self, event: &Event) -> Result<(), MetricsError> {
        self.file.write_all(&frame(&event.encode_to_vec())).map_err(io_err(&self.path))?;
        self.file.flush().map_err(io_err(&self.path))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Reads the events of a file written by [`EventWriter`], checking every frame's checksums
    /// (TensorBoard reads the files itself; this checks what it will read).
    fn read_events(path: &Path) -> Result<Vec<Event>, String> {
        let bytes = std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?;
        let mut events = Vec::new();
        let mut rest = bytes.as_slice();
        while !rest.is_empty() {
            let take = |rest: &mut &[u8], n: usize| -> Result<Vec<u8>, String> {
                if rest.len() < n {
                    return Err("truncated frame".into());
                }
                let (a, b) = rest.split_at(n);
                *rest = b;
                Ok(a.to_vec())
            };
            let len = take(&mut rest, 8)?;
            let crc = u32::from_le_bytes(take(&mut rest, 4)?.try_into().expect("4 bytes"));
            if crc != masked_crc32c(&len) {
                return Err("length checksum mismatch".into());
            }
            let n = u64::from_le_bytes(len.try_into().expect("8 bytes"));
            let n = usize::try_from(n).map_err(|_| "frame too long".to_string())?;
            let payload = take(&mut rest, n)?;
            let crc = u32::from_le_bytes(take(&mut rest, 4)?.try_into().expect("4 bytes"));
            if crc != masked_crc32c(&payload) {
                return Err("payload checksum mismatch".into());
            }
            events.push(Event::decode(payload.as_slice()).map_err(|e| e.to_string())?);
        }
        Ok(events)
    }

    #[test]
    fn crc32c_is_castagnoli_and_masked_as_tfrecord_does() {
        // CRC-32C check value of "123456789" (RFC 3720 §B.4 lists the polynomial; 0xE3069283 is
        // the standard check value).
        assert_eq!(CASTAGNOLI.checksum(b"123456789"), 0xE306_9283);
        // TFRecord's mask: rotate right by 15 bits, add 0xa282ead8 (worked out by hand).
        assert_eq!(masked_crc32c(b"123456789"), 0xC78A_B0E5);
    }

    #[test]
    fn the_first_event_names_the_version_and_scalars_read_back() {
        let dir = tempfile::tempdir().unwrap();
        let mut w = EventWriter::create(&dir.path().join("tb"), Some(5)).unwrap();
        w.scalars(5, &[("train/alpha", 0.25), ("J", 12.5)]).unwrap();
        let events = read_events(w.path()).unwrap();
        assert_eq!(events.len(), 3);
        assert_eq!(events[0].file_version.as_deref(), Some(FILE_VERSION));
        assert_eq!((events[1].step, events[1].session_log.as_ref().map(|s| s.status)), (5, Some(1)));
        let s = events[2].summary.as_ref().unwrap();
        assert_eq!(events[2].step, 5);
        assert_eq!(s.value[0].tag, "train/alpha");
        assert_eq!((s.value[0].simple_value, s.value[1].simple_value), (Some(0.25), Some(12.5)));
        assert!(w.path().file_name().unwrap().to_str().unwrap().starts_with("events.out.tfevents."));
    }

    #[test]
    fn a_flipped_byte_is_caught_by_the_frame_checksums() {
        let dir = tempfile::tempdir().unwrap();
        let mut w = EventWriter::create(dir.path(), None).unwrap();
        w.scalars(0, &[("a", 1.0)]).unwrap();
        let mut bytes = std::fs::read(w.path()).unwrap();
        let last = bytes.len() - 6;
        bytes[last] ^= 0x40;
        std::fs::write(w.path(), &bytes).unwrap();
        assert!(read_events(w.path()).unwrap_err().contains("checksum"));
    }
}
