//! Temporary files and folders being written right now, so that a run
//! stopped by Ctrl-C or SIGTERM (a Slurm job's time limit) can remove
//! them on its way out instead of leaving `.NAME.PID.part` files beside
//! the user's outputs until the next run of the same command finds them.
//!
//! The writers hold an [`InFlight`] guard while their temporary exists;
//! the binary's signal handler (a normal thread, not the signal context)
//! calls [`remove_in_flight`]. Outputs already renamed into place are
//! never on the list, so an interrupted run keeps every finished file.

use std::path::{Path, PathBuf};
use std::sync::Mutex;

static IN_FLIGHT: Mutex<Vec<(u64, PathBuf)>> = Mutex::new(Vec::new());
static NEXT_ID: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

/// A temporary file or folder listed as being written, for as long as the
/// guard lives. Dropping it takes it off the list (the writer has renamed
/// or removed it by then).
#[derive(Debug)]
pub struct InFlight {
    id: u64,
}

impl InFlight {
    /// Lists `path` (a file, or a folder removed with what it holds).
    pub fn new(path: &Path) -> InFlight {
        let id = NEXT_ID.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        lock().push((id, path.to_path_buf()));
        InFlight { id }
    }
}

impl Drop for InFlight {
    fn drop(&mut self) {
        lock().retain(|(id, _)| *id != self.id);
    }
}

fn lock() -> std::sync::MutexGuard<'static, Vec<(u64, PathBuf)>> {
    // A writer that panicked while the list was locked leaves it as it
    // was: still a list of paths, still worth removing.
    IN_FLIGHT.lock().unwrap_or_else(|e| e.into_inner())
}

/// Removes every listed temporary (files, and folders with their
/// content) and empties the list; returns the paths removed. Called when
/// the process is about to end on a signal: the writers are not told, so
/// call it only on the way out.
pub fn remove_in_flight() -> Vec<PathBuf> {
    remove_where(|_| true)
}

/// [`remove_in_flight`] for the listed paths `pick` selects.
fn remove_where(pick: impl Fn(&Path) -> bool) -> Vec<PathBuf> {
    let listed: Vec<PathBuf> = {
        let mut all = lock();
        let (picked, kept): (Vec<_>, Vec<_>) = all.drain(..).partition(|(_, p)| pick(p));
        *all = kept;
        picked.into_iter().map(|(_, p)| p).collect()
    };
    listed
        .into_iter()
        .filter(|p| {
            let removed = if p.is_dir() {
                std::fs::remove_dir_all(p)
            } else {
                std::fs::remove_file(p)
            };
            removed.is_ok()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn listed_temporaries_are_removed_and_finished_ones_are_not() {
        let d = tempfile::tempdir().unwrap();
        let part = d.path().join(".s.mp4.1.part");
        let done = d.path().join(".t.csv.1.tmp");
        let folder = d.path().join(".report.tmp1");
        std::fs::write(&part, b"half").unwrap();
        std::fs::write(&done, b"whole").unwrap();
        std::fs::create_dir_all(folder.join("figures")).unwrap();
        std::fs::write(folder.join("figures/a.png"), b"x").unwrap();
        let _writing = InFlight::new(&part);
        let _report = InFlight::new(&folder);
        // A writer that finished drops its guard before the signal.
        drop(InFlight::new(&done));
        // Only this test's paths: other tests write beside it.
        let removed = remove_where(|p| p.starts_with(d.path()));
        assert!(removed.contains(&part) && removed.contains(&folder));
        assert!(!removed.contains(&done));
        assert!(!part.exists() && !folder.exists());
        assert!(done.exists(), "a finished file is not touched");
        assert!(!lock().iter().any(|(_, p)| p.starts_with(d.path())));
    }
}
