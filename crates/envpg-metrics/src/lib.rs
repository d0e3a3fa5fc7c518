//! # envpg-metrics
//!
//! Live training metrics: per-iteration scalars written as they happen, so a run can be
//! watched while it trains (`tail -f metrics.csv`, or TensorBoard).
//!
//! ## Main types
//! - [`MetricsWriter`]: opened once per run with the names of its scalars; each
//!   [`record`](MetricsWriter::record) appends one row to a CSV file and, if asked, one event
//!   to a TensorBoard event file, flushing both, so a reader sees every completed iteration.
//! - [`csv`]: the CSV side, including the truncation a resumed run needs.
//! - [`tensorboard`]: TensorBoard event files (TFRecord frames of `tensorflow.Event`
//!   protobuf messages), readable by the `tensorboard` package without TensorFlow.
//!
//! ## Data flow
//! driver (each iteration's progress) → [`MetricsWriter::record`] → `metrics.csv` and
//! `events.out.tfevents.*` → a person watching the run.
//!
//! A resumed run re-opens the same files: rows of iterations at or after the one it resumes
//! from (written after its checkpoint, before the interruption) are dropped from the CSV, and
//! the TensorBoard file gets a restart marker at that step, which TensorBoard uses to discard
//! the earlier file's later points.
//!
//! ```
//! use envpg_metrics::MetricsWriter;
//! let dir = tempfile::tempdir()?;
//! let csv = dir.path().join("metrics.csv");
//! let mut m = MetricsWriter::create(&csv, None, &["alpha", "J_exact"], None)?;
//! m.record(0, &[Some(1.0), None])?;
//! m.record(1, &[Some(0.5), Some(12.5)])?;
//! assert_eq!(std::fs::read_to_string(&csv)?, "k,alpha,J_exact\n0,1.0,\n1,0.5,12.5\n");
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

pub mod csv;
pub mod tensorboard;

use std::path::{Path, PathBuf};

/// Why metrics could not be written.
#[derive(Debug, thiserror::Error)]
pub enum MetricsError {
    /// A file could not be created, read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// A row does not have one value per column.
    #[error("a metrics row has {got} values for {expected} columns")]
    Shape {
        /// Values given.
        got: usize,
        /// Columns declared.
        expected: usize,
    },
    /// A column name that cannot be a CSV header or a TensorBoard tag.
    #[error("metric name {0:?}: use letters, digits, '_' and '/' only")]
    Name(String),
}

pub(crate) fn io_err(path: &Path) -> impl FnOnce(std::io::Error) -> MetricsError + '_ {
    move |source| MetricsError::Io { path: path.to_owned(), source }
}

/// Writes a run's per-iteration scalars to a CSV file and, optionally, TensorBoard.
#[derive(Debug)]
pub struct MetricsWriter {
    columns: Vec<String>,
    csv: csv::CsvWriter,
    tensorboard: Option<tensorboard::EventWriter>,
}

impl MetricsWriter {
    /// Opens the metrics of a run: the CSV file `csv` (created, or for a resumed run, kept
    /// up to iteration `resume_from` and appended to) and, with `tensorboard`, a new event file
    /// in that directory (created if missing). Column names are also the TensorBoard tags.
    pub fn create(
        csv: &Path,
        tensorboard: Option<&Path>,
        columns: &[&str],
        resume_from: Option<u64>,
    ) -> Result<Self, MetricsError> {
        for c in columns {
            let ok = !c.is_empty() && c.chars().all(|ch| ch.is_ascii_alphanumeric() || ch == '_' || ch == '/');
            if !ok || *c == "k" {
                return Err(MetricsError::Name((*c).to_owned()));
            }
        }
        let csv = csv::CsvWriter::open(csv, columns, resume_from)?;
        let tensorboard = tensorboard.map(|d| tensorboard::EventWriter::create(d, resume_from)).transpose()?;
        Ok(Self { columns: columns.iter().map(|c| (*c).to_owned()).collect(), csv, tensorboard })
    }

    /// The CSV file.
    pub fn csv_path(&self) -> &Path {
        self.csv.path()
    }

    /// The TensorBoard event file, if any.
    pub fn event_file(&self) -> Option<&Path> {
        self.tensorboard.as_ref().map(|t| t.path())
    }

    /// Records iteration `k`: one value per column, `None` where there is none this iteration
    /// (an empty CSV field; no TensorBoard point). Both files are flushed before it returns.
    pub fn record(&mut self, k: u64, values: &[Option<f64>]) -> Result<(), MetricsError> {
        if values.len() != self.columns.len() {
            return Err(MetricsError::Shape { got: values.len(), expected: self.columns.len() });
        }
        self.csv.row(k, values)?;
        if let Some(tb) = &mut self.tensorboard {
            let scalars: Vec<(&str, f64)> = self
                .columns
                .iter()
                .zip(values)
                .filter_map(|(c, v)| v.filter(|v| v.is_finite()).map(|v| (c.as_str(), v)))
                .collect();
            tb.scalars(k, &scalars)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_that_cannot_be_headers_or_tags_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let csv = dir.path().join("m.csv");
        for bad in ["", "a,b", "k", "J exact", "x\n"] {
            assert!(matches!(MetricsWriter::create(&csv, None, &[bad], None), Err(MetricsError::Name(_))), "{bad:?}");
        }
        let mut m = MetricsWriter::create(&csv, None, &["train/alpha"], None).unwrap();
        assert!(matches!(m.record(0, &[]), Err(MetricsError::Shape { got: 0, expected: 1 })));
    }

    #[test]
    fn an_unwritable_place_is_an_error_naming_it() {
        let e = MetricsWriter::create(Path::new("/proc/nope/m.csv"), None, &["a"], None).unwrap_err();
        assert!(e.to_string().contains("/proc/nope/m.csv"), "{e}");
    }
}
