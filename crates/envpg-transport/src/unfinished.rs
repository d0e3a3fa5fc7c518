//! [`remove_unfinished_segments`]: shared-memory files whose creator died before sizing them.
//!
//! iceoryx2 0.10 creates a segment write-only, sizes it, initialises it, then makes it
//! readable. A process killed between the first two steps leaves a zero-length, write-only
//! `iox2_*` file in `/dev/shm`; opening it (as every node creation does while it cleans up the
//! dead node that used it) waits for it to be sized — without end, as the wait for a zero-length
//! file has no time limit. One such file made every later launch on the host hang at start. A
//! live creator sizes its file within microseconds, so one still empty and write-only after
//! [`SETTLE`] is garbage, and removing it turns the endless wait into a failed open, which the
//! cleanup reports and passes over.

use std::os::unix::fs::{MetadataExt, PermissionsExt};
use std::path::{Path, PathBuf};
use std::time::{Duration, SystemTime};

/// Where iceoryx2's POSIX shared memory lives.
pub const SHM_DIR: &str = "/dev/shm";

/// How long a file may stay empty and write-only before it counts as abandoned.
pub const SETTLE: Duration = Duration::from_secs(2);

/// Removes the abandoned segments in [`SHM_DIR`] (see the module docs); returns their paths.
pub fn remove_unfinished_segments() -> Vec<PathBuf> {
    remove_unfinished_in(Path::new(SHM_DIR), SETTLE)
}

/// [`remove_unfinished_segments`] in `dir`, counting a file abandoned once it has been empty and
/// write-only for `settle` (by its modification time; a younger one is waited for, then looked
/// at again). Other users' files, and files whose metadata cannot be read, are left alone.
pub fn remove_unfinished_in(dir: &Path, settle: Duration) -> Vec<PathBuf> {
    let mut removed = Vec::new();
    let Ok(entries) = std::fs::read_dir(dir) else { return removed };
    // SAFETY: geteuid(2) cannot fail.
    let me = unsafe { libc::geteuid() };
    let unfinished = |path: &Path| -> Option<(u64, SystemTime)> {
        let meta = std::fs::symlink_metadata(path).ok()?;
        let empty_write_only =
            meta.is_file() && meta.len() == 0 && meta.permissions().mode() & 0o400 == 0 && meta.uid() == me;
        empty_write_only.then_some((meta.ino(), meta.modified().ok()?))
    };
    let candidates: Vec<PathBuf> = entries
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().starts_with("iox2_"))
        .map(|e| e.path())
        .filter(|p| unfinished(p).is_some())
        .collect();
    for path in candidates {
        let Some((inode, modified)) = unfinished(&path) else { continue };
        let age = SystemTime::now().duration_since(modified).unwrap_or_default();
        if age < settle {
            std::thread::sleep(settle - age);
        }
        // Still the same file, still empty and write-only: its creator is gone.
        if unfinished(&path).is_some_and(|(i, m)| i == inode && m == modified) && std::fs::remove_file(&path).is_ok() {
            removed.push(path);
        }
    }
    removed
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::fs::{File, OpenOptions};
    use std::io::Write;

    fn make(dir: &Path, name: &str, bytes: &[u8], mode: u32, age: Duration) -> PathBuf {
        let path = dir.join(name);
        let mut f = OpenOptions::new().create(true).truncate(true).write(true).open(&path).unwrap();
        f.write_all(bytes).unwrap();
        f.set_modified(SystemTime::now() - age).unwrap();
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(mode)).unwrap();
        path
    }

    /// Only empty, write-only `iox2_` files are removed, old ones at once and young ones once
    /// they have stayed so for the settling time; a young one its creator sizes meanwhile stays.
    #[test]
    fn only_segments_left_empty_and_write_only_are_removed() {
        let dir = tempfile::tempdir().unwrap();
        let old = Duration::from_secs(60);
        let abandoned = make(dir.path(), "iox2_a_1.dynamic", b"", 0o200, old);
        let readable = make(dir.path(), "iox2_b_2.dynamic", b"", 0o600, old);
        let sized = make(dir.path(), "iox2_c_3.data", b"x", 0o200, old);
        let foreign = make(dir.path(), "other_4.dynamic", b"", 0o200, old);
        let young_abandoned = make(dir.path(), "iox2_d_5.dynamic", b"", 0o200, Duration::ZERO);
        let young_finished = make(dir.path(), "iox2_e_6.dynamic", b"", 0o200, Duration::ZERO);
        // A live creator sizes and opens up its file well within the settling time.
        let finisher = {
            let path = young_finished.clone();
            std::thread::spawn(move || {
                std::thread::sleep(Duration::from_millis(50));
                File::options().write(true).open(&path).unwrap().write_all(b"ready").unwrap();
                std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o600)).unwrap();
            })
        };
        let mut removed = remove_unfinished_in(dir.path(), Duration::from_millis(400));
        finisher.join().unwrap();
        removed.sort();
        assert_eq!(removed, vec![abandoned.clone(), young_abandoned.clone()]);
        assert!(!abandoned.exists() && !young_abandoned.exists());
        for kept in [readable, sized, foreign, young_finished] {
            assert!(kept.exists(), "{} was removed", kept.display());
        }
    }
}
