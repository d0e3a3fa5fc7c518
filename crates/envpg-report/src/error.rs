//! [`ReportError`]: why an experiment or a report failed.

use std::path::PathBuf;

/// Why an experiment or a report failed.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// A file could not be written or read.
    #[error("{path}: {err}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        err: std::io::Error,
    },
    /// A result file is unusable.
    #[error(transparent)]
    Result(#[from] envpg_core::result::ResultError),
    /// The plan itself is invalid (settings, ranges, a directory holding another experiment).
    #[error("{0}")]
    Plan(String),
    /// Some runs failed; the others were kept and reported.
    #[error("{failed} of {total} runs failed; first: {first}")]
    Runs {
        /// Failed runs.
        failed: usize,
        /// All runs.
        total: usize,
        /// The first failure.
        first: String,
    },
    /// A figure could not be drawn.
    #[error("drawing {path}: {reason}")]
    Draw {
        /// The figure file.
        path: PathBuf,
        /// What went wrong.
        reason: String,
    },
    /// The run was interrupted.
    #[error("interrupted")]
    Interrupted,
}

impl ReportError {
    /// An I/O error on `path`.
    pub fn io(path: impl Into<PathBuf>, err: std::io::Error) -> Self {
        Self::Io { path: path.into(), err }
    }
}
