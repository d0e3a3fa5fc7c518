//! Atomic file writes and early output checks: nothing already computed is lost to a crash
//! mid-write, and an output that cannot be written is found before the work, not after it.

use std::io::Write;
use std::path::Path;

/// Writes `bytes` to `path` atomically: a temporary file in the same directory, `fsync`, then
/// `rename` over the target. Readers see either the old file or the complete new one.
pub fn write_atomic(path: impl AsRef<Path>, bytes: &[u8]) -> std::io::Result<()> {
    write_atomic_with(path, |w| w.write_all(bytes))
}

/// [`write_atomic`] of what `write` writes, streamed to the temporary file (through a buffer),
/// so a large output is never held in memory whole.
pub fn write_atomic_with(
    path: impl AsRef<Path>,
    write: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> std::io::Result<()> {
    let path = path.as_ref();
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_owned(),
        _ => std::path::PathBuf::from("."),
    };
    std::fs::create_dir_all(&dir)?;
    let name = path.file_name().ok_or_else(|| {
        std::io::Error::new(std::io::ErrorKind::InvalidInput, format!("{} has no file name", path.display()))
    })?;
    let tmp = dir.join(format!(".{}.tmp.{}", name.to_string_lossy(), std::process::id()));
    let written = (|| {
        let mut f = std::io::BufWriter::new(std::fs::File::create(&tmp)?);
        write(&mut f)?;
        f.into_inner().map_err(|e| e.into_error())?.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if written.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    written?;
    // Make the rename itself durable.
    if let Ok(d) = std::fs::File::open(&dir) {
        let _ = d.sync_all();
    }
    Ok(())
}

/// Checks, before any work, that a file can be written at `path`: it is not a directory, and
/// its directory exists (or is created now) and accepts a new file. The error names the path.
pub fn check_writable(path: impl AsRef<Path>) -> std::io::Result<()> {
    let path = path.as_ref();
    let named = |e: std::io::Error| std::io::Error::new(e.kind(), format!("cannot write {}: {e}", path.display()));
    if path.is_dir() {
        return Err(named(std::io::Error::new(std::io::ErrorKind::IsADirectory, "it is a directory")));
    }
    if path.file_name().is_none() {
        return Err(named(std::io::Error::new(std::io::ErrorKind::InvalidInput, "no file name")));
    }
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_owned(),
        _ => std::path::PathBuf::from("."),
    };
    probe_dir(&dir).map_err(named)
}

/// Checks, before any work, that `dir` exists (or is created now) and accepts new files.
pub fn check_dir_writable(dir: impl AsRef<Path>) -> std::io::Result<()> {
    let dir = dir.as_ref();
    probe_dir(dir).map_err(|e| std::io::Error::new(e.kind(), format!("cannot write into {}: {e}", dir.display())))
}

fn probe_dir(dir: &Path) -> std::io::Result<()> {
    std::fs::create_dir_all(dir)?;
    // A real file, not just the permission bits: read-only mounts and full quotas show here.
    let probe = tempfile::Builder::new().prefix(".envpg-write-check").tempfile_in(dir)?;
    probe.close()
}

/// Creates `dir` (and missing parents) readable, writable and listable by the owner only
/// (mode 0700 on what is created; an existing directory keeps its mode).
pub fn create_private_dir(dir: impl AsRef<Path>) -> std::io::Result<()> {
    use std::os::unix::fs::DirBuilderExt;
    std::fs::DirBuilder::new().recursive(true).mode(0o700).create(dir)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn replaces_content_and_leaves_no_temp_file() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("sub/r.json");
        write_atomic(&p, b"one").unwrap();
        write_atomic(&p, b"two").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"two");
        let names: Vec<_> = std::fs::read_dir(p.parent().unwrap()).unwrap().collect();
        assert_eq!(names.len(), 1);
    }

    #[test]
    fn a_write_that_fails_midway_keeps_the_old_file_and_leaves_no_temp_file() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("r.bin");
        write_atomic_with(&p, |w| w.write_all(b"old")).unwrap();
        let e = write_atomic_with(&p, |w| {
            w.write_all(&[7; 100_000])?;
            Err(std::io::Error::other("serialiser gave up"))
        })
        .unwrap_err();
        assert!(e.to_string().contains("serialiser gave up"), "{e}");
        assert_eq!(std::fs::read(&p).unwrap(), b"old");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1, "the temporary file is removed");
    }

    #[test]
    fn output_checks_refuse_unwritable_places_and_leave_nothing_behind() {
        let dir = tempfile::tempdir().unwrap();
        check_writable(dir.path().join("new/sub/r.json")).unwrap();
        assert_eq!(std::fs::read_dir(dir.path().join("new/sub")).unwrap().count(), 0, "the probe is removed");
        let e = check_writable("/proc/nope/r.json").unwrap_err().to_string();
        assert!(e.contains("/proc/nope/r.json"), "{e}");
        let e = check_writable(dir.path()).unwrap_err().to_string();
        assert!(e.contains("directory"), "{e}");
        assert!(check_dir_writable("/proc/nope").is_err());
        check_dir_writable(dir.path().join("d")).unwrap();
    }

    #[test]
    fn private_directories_are_owner_only() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a/b");
        create_private_dir(&p).unwrap();
        for d in [dir.path().join("a"), p] {
            assert_eq!(std::fs::metadata(&d).unwrap().permissions().mode() & 0o777, 0o700, "{}", d.display());
        }
    }
}
