//! [`CsvWriter`]: `k` and one column per scalar, a row per iteration, flushed per row.

use std::fs::{File, OpenOptions};
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};

use crate::{MetricsError, io_err};

/// Appends rows to a metrics CSV file.
#[derive(Debug)]
pub struct CsvWriter {
    path: PathBuf,
    file: File,
}

impl CsvWriter {
    /// Creates `path` with a header of `k` and `columns`; for a resumed run (`resume_from`
    /// = the first iteration it will record) an existing file with the same header keeps its
    /// rows of earlier iterations and is appended to (rows at or after `resume_from`, written
    /// after the checkpoint, are dropped; a file with another header is started afresh).
    pub fn open(path: &Path, columns: &[&str], resume_from: Option<u64>) -> Result<Self, MetricsError> {
        let header = std::iter::once("k").chain(columns.iter().copied()).collect::<Vec<_>>().join(",");
        let kept = match resume_from {
            Some(k) => kept_rows(path, &header, k)?,
            None => Vec::new(),
        };
        let mut text = format!("{header}\n");
        for row in kept {
            text.push_str(&row);
            text.push('\n');
        }
        // Rewritten whole (it is small, and only at start), atomically: an interrupted rewrite
        // leaves the rows it had.
        envpg_core::io::write_atomic(path, text.as_bytes()).map_err(io_err(path))?;
        let file = OpenOptions::new().append(true).open(path).map_err(io_err(path))?;
        Ok(Self { path: path.to_owned(), file })
    }

    /// The file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Appends the row of iteration `k` and flushes it to the OS.
    pub fn row(&mut self, k: u64, values: &[Option<f64>]) -> Result<(), MetricsError> {
        let mut line = k.to_string();
        for v in values {
            line.push(',');
            if let Some(v) = v {
                // Shortest round-trip form (exponent for tiny and huge values): the value read back is
                // the value written.
                line.push_str(&format!("{v:?}"));
            }
        }
        line.push('\n');
        // One write per row: `tail -f` and concurrent readers see whole rows.
        self.file.write_all(line.as_bytes()).map_err(io_err(&self.path))?;
        self.file.flush().map_err(io_err(&self.path))
    }
}

/// Rows of `path` before iteration `k`, if its header is `header`.
fn kept_rows(path: &Path, header: &str, k: u64) -> Result<Vec<String>, MetricsError> {
    let file = match File::open(path) {
        Ok(f) => f,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(io_err(path)(e)),
    };
    let mut lines = BufReader::new(file).lines();
    match lines.next().transpose().map_err(io_err(path))? {
        Some(h) if h == header => {}
        _ => return Ok(Vec::new()),
    }
    let columns = header.split(',').count();
    let mut rows = Vec::new();
    for line in lines {
        let line = line.map_err(io_err(path))?;
        // A torn last line (killed mid-write) or a later iteration is not kept.
        let row_k = line.split(',').next().and_then(|f| f.parse::<u64>().ok());
        if row_k.is_some_and(|rk| rk < k) && line.split(',').count() == columns {
            rows.push(line);
        }
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_read_back_exactly_and_missing_ones_are_empty() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("m.csv");
        let mut w = CsvWriter::open(&p, &["a", "b"], None).unwrap();
        let x = 0.1f64 + 0.2;
        w.row(0, &[Some(x), None]).unwrap();
        w.row(1, &[Some(-1e-300), Some(f64::INFINITY)]).unwrap();
        let text = std::fs::read_to_string(&p).unwrap();
        let rows: Vec<&str> = text.lines().collect();
        assert_eq!(rows[0], "k,a,b");
        assert_eq!(rows[1].split(',').nth(1).unwrap().parse::<f64>().unwrap(), x);
        assert_eq!(rows[1], format!("0,{x},"));
        assert_eq!(rows[2], "1,-1e-300,inf");
    }

    #[test]
    fn a_resumed_run_keeps_earlier_rows_and_drops_later_and_torn_ones() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("m.csv");
        std::fs::write(&p, "k,a\n0,1\n1,2\n2,3\n3,4\n4,").unwrap();
        let mut w = CsvWriter::open(&p, &["a"], Some(3)).unwrap();
        w.row(3, &[Some(9.0)]).unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "k,a\n0,1\n1,2\n2,3\n3,9.0\n");
        // Another header: the old file is not this run's; it starts afresh.
        std::fs::write(&p, "k,other\n0,1\n").unwrap();
        CsvWriter::open(&p, &["a"], Some(3)).unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "k,a\n");
        // Not resumed: always afresh.
        std::fs::write(&p, "k,a\n0,1\n").unwrap();
        CsvWriter::open(&p, &["a"], None).unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "k,a\n");
    }
}
