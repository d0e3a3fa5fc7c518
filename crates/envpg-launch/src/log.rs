//! The run's log: every process of a run (launcher, learner, workers) writes its log lines to
//! stderr and, once it knows the run directory, appends them to `DIR/log.txt` too (without
//! colours).

use std::fs::File;
use std::io::Write;
use std::path::Path;
use std::sync::{Mutex, OnceLock};

static FILE: OnceLock<Mutex<File>> = OnceLock::new();

/// `DIR/log.txt`.
pub fn path(dir: &Path) -> std::path::PathBuf {
    dir.join("log.txt")
}

/// From now on, also append log lines to `DIR/log.txt` (the first call wins). A log that
/// cannot be opened is said once on stderr; the run goes on.
pub fn keep_in(dir: &Path) {
    let p = path(dir);
    match std::fs::OpenOptions::new().create(true).append(true).open(&p) {
        Ok(f) => {
            let _ = FILE.set(Mutex::new(f));
        }
        Err(e) => eprintln!("warning: cannot keep the run's log in {}: {e}", p.display()),
    }
}

/// Appends `line` to the run's log file (if kept) without printing it.
pub fn to_file(line: &str) {
    let _ = LogFile.write_all(format!("{line}\n").as_bytes());
}

/// A writer to the run's log file (nothing until [`keep_in`]).
pub struct LogFile;

impl Write for LogFile {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        if let Some(f) = FILE.get()
            && let Ok(mut f) = f.lock()
        {
            // One write per formatted event: processes appending to one file interleave whole
            // lines.
            let _ = f.write_all(buf);
        }
        Ok(buf.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}
