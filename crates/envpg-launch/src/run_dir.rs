//! The run directory: `run.json` (everything the learner and worker processes need) and the
//! learner's checkpoint.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use envpg_ac::trainer::RunSpec;
use serde::{Deserialize, Serialize};

/// `run.json`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct RunFile {
    /// Run id (service names).
    pub run_id: String,
    /// The run.
    pub spec: RunSpec,
    /// Result file path.
    pub out: PathBuf,
    /// Worker processes.
    pub workers: usize,
    /// Checkpoint period (0: none).
    pub checkpoint_every: u64,
    /// Extra compute per environment step (µs).
    pub emulator_cost_us: u64,
    /// Silence after which a worker is presumed dead (ms).
    pub worker_timeout_ms: u64,
    /// The learner gives up after this long without any episode while work is pending (s).
    #[serde(default = "default_stall")]
    pub stall_timeout_s: u64,
    /// zenoh endpoint on which remote worker hosts join (multi-host runs).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub listen: Option<String>,
    /// Where TensorBoard event files go (`--tensorboard`), besides `metrics.csv`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tensorboard: Option<PathBuf>,
    /// Passes of Algorithm 1 (`--passes`); each pass above one runs in `pass-P/` of the run
    /// directory, with a `run.json` of its own.
    #[serde(default = "one", skip_serializing_if = "is_one")]
    pub passes: usize,
    /// Where the passes after the first start (`--pass-start`). A run file without it was
    /// written before the option, when every later pass started from the best design (today's
    /// default).
    #[serde(default)]
    pub pass_start: crate::passes::PassStart,
}

fn one() -> usize {
    1
}

fn is_one(n: &usize) -> bool {
    *n == 1
}

fn default_stall() -> u64 {
    60
}

impl RunFile {
    /// `DIR/run.json`.
    pub fn path(dir: &Path) -> PathBuf {
        dir.join("run.json")
    }
    /// `DIR/checkpoint.bin`.
    pub fn checkpoint_path(dir: &Path) -> PathBuf {
        dir.join("checkpoint.bin")
    }
    /// Reads `DIR/run.json`.
    pub fn load(dir: &Path) -> Result<Self> {
        let p = Self::path(dir);
        let text = std::fs::read_to_string(&p).with_context(|| format!("reading {}", p.display()))?;
        serde_json::from_str(&text).with_context(|| format!("parsing {}", p.display()))
    }
    /// `DIR/result.json`: the run directory's copy of the result (the only one when `--out`
    /// could not be written any more).
    pub fn result_copy_path(dir: &Path) -> PathBuf {
        dir.join("result.json")
    }
    /// The checkpoint policy of this run: every `checkpoint_every` iterations, and always when
    /// stopped and at the end of training.
    pub fn checkpoint_policy(&self, dir: &Path) -> envpg_learner::CheckpointPolicy {
        envpg_learner::CheckpointPolicy { path: Self::checkpoint_path(dir), every: self.checkpoint_every }
    }
    /// Reads `DIR/checkpoint.bin` and checks that it belongs to this run (same run id, same
    /// run description).
    pub fn load_checkpoint(&self, dir: &Path) -> Result<envpg_protocol::Checkpoint, envpg_protocol::CheckpointError> {
        let path = Self::checkpoint_path(dir);
        let c = envpg_protocol::Checkpoint::load(&path)?;
        let spec = serde_json::to_string(&self.spec).expect("a run description serialises");
        c.check_for(&path, &self.run_id, &spec)?;
        Ok(c)
    }
    /// Writes `DIR/run.json` atomically.
    pub fn save(&self, dir: &Path) -> Result<()> {
        let p = Self::path(dir);
        let text = serde_json::to_string_pretty(self)?;
        envpg_core::io::write_atomic(&p, text.as_bytes()).with_context(|| format!("writing {}", p.display()))
    }
}

/// Writes a finished run's result to `out`; if that fails (disk full, directory removed since
/// the start), writes it into the run directory instead and fails naming both paths, so a
/// finished run's result is never lost.
pub fn save_result(result: &envpg_core::ResultFile, out: &Path, dir: &Path) -> Result<()> {
    // The run directory keeps its own copy, beside its metrics, checkpoints and log.
    let copy = RunFile::result_copy_path(dir);
    let kept = result.save(&copy);
    match (result.save(out), kept) {
        (Ok(()), Ok(())) => Ok(()),
        (Ok(()), Err(e)) => {
            tracing::warn!("the run directory's copy of the result, {}: {e}", copy.display());
            Ok(())
        }
        (Err(e), Ok(())) => anyhow::bail!(
            "writing {} failed ({e}); the result was written to {} instead",
            out.display(),
            copy.display()
        ),
        (Err(e), Err(e2)) => anyhow::bail!(
            "writing {} failed ({e}), and so did writing it to {} ({e2}); the result is lost",
            out.display(),
            copy.display()
        ),
    }
}

/// A fresh run id: 12 hex digits from the time, the process id and per-process randomness.
pub fn new_run_id() -> String {
    let t = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.as_nanos()).unwrap_or(0);
    use std::hash::BuildHasher;
    // RandomState is seeded from the OS per process: two launches in the same nanosecond differ.
    let mix = std::collections::hash_map::RandomState::new().hash_one((t, std::process::id()));
    format!("{:012x}", mix & 0xffff_ffff_ffff)
}
