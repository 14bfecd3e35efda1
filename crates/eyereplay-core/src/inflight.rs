//! Temporary files and folders being written right now, so that a run
//! stopped by Ctrl-C or SIGTERM (a Slurm job's time limit) can remove
//! them on its way out instead of leaving `.NAME.PID.part` files beside
//! the user's outputs until the next run of the same command finds them.
//!
//! The writers hold an [`InFlight`] guard while their temporary exists,
//! and the owner of a child process that writes one (eyereplay-render's
//! FFmpeg `Encoder`) a [`ChildInFlight`]; the binary's signal handler (a normal thread, not
//! the signal context) calls [`remove_in_flight`]. Outputs already renamed
//! into place are never on the list, so an interrupted run keeps every
//! finished file.
//!
//! The handler runs while the other threads go on working, so the steps
//! that create a temporary or rename one into place run inside
//! [`guarded`]: a stop waits for the step in progress to end and lets no
//! new one start. Without that, a stop between the two renames of a
//! report's swap lost the old report, and a writer could make again a
//! folder the handler had just removed.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU8, Ordering};
use std::sync::{Mutex, RwLock};

/// Entries listed for as long as their guards live: temporaries being
/// written (paths), or the child processes writing them (pids).
struct List<T>(Mutex<Vec<(u64, T)>>);

impl<T> List<T> {
    const fn new() -> List<T> {
        List(Mutex::new(Vec::new()))
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Vec<(u64, T)>> {
        // A writer that panicked while the list was locked leaves it as
        // it was: still a list, still worth going through.
        self.0.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Lists `item`; the id takes it off again.
    fn add(&self, item: T) -> u64 {
        let id = NEXT_ID.fetch_add(1, Ordering::Relaxed);
        self.lock().push((id, item));
        id
    }

    fn remove(&self, id: u64) {
        self.lock().retain(|(i, _)| *i != id);
    }
}

static IN_FLIGHT: List<PathBuf> = List::new();
static CHILDREN: List<u32> = List::new();
static NEXT_ID: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
/// Read-held by [`guarded`] steps; write-held, for good, by a stop.
static GATE: RwLock<()> = RwLock::new(());
/// The process's state: its work running, a stop under way, or the work
/// finished (outputs in place, the process about to exit on its own).
/// Whichever of a stop and the work's end comes first wins.
struct RunState(AtomicU8);

const RUNNING: u8 = 0;
const STOPPING: u8 = 1;
const FINISHED: u8 = 2;

impl RunState {
    const fn new() -> RunState {
        RunState(AtomicU8::new(RUNNING))
    }

    fn stopping(&self) -> bool {
        self.0.load(Ordering::SeqCst) == STOPPING
    }

    /// True if the work is now finished (or was); false if a stop began.
    fn finish(&self) -> bool {
        self.0
            .compare_exchange(RUNNING, FINISHED, Ordering::SeqCst, Ordering::SeqCst)
            .map_or_else(|state| state == FINISHED, |_| true)
    }

    /// True if a stop may go on (it began now, or was already under way);
    /// false once the work has finished.
    fn begin_stop(&self) -> bool {
        self.0
            .compare_exchange(RUNNING, STOPPING, Ordering::SeqCst, Ordering::SeqCst)
            .map_or_else(|state| state == STOPPING, |_| true)
    }
}

static STATE: RunState = RunState::new();

/// Runs `step`, a file operation that creates a listed temporary or
/// renames one into place, so that a stop never falls in its middle: a
/// stop waits for it to end, and once a stop has begun no step starts
/// (it waits until the process ends). A step inside a step runs as part
/// of the outer one (taking the gate again would wait on a stop that waits
/// on the outer step).
pub fn guarded<R>(step: impl FnOnce() -> R) -> R {
    thread_local! {
        static INSIDE: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
    }
    if INSIDE.with(|i| i.get()) {
        return step();
    }
    let _held = GATE.read().unwrap_or_else(|e| e.into_inner());
    INSIDE.with(|i| i.set(true));
    // Reset even if the step panics.
    struct Leave;
    impl Drop for Leave {
        fn drop(&mut self) {
            INSIDE.with(|i| i.set(false));
        }
    }
    let _leave = Leave;
    step()
}

/// Whether a stop has begun: the process is about to end, so a thread
/// that finds its work failed should not report it (the failure may be
/// the stop's removal of its files).
pub fn stopping() -> bool {
    STATE.stopping()
}

/// Marks the command's work finished, so that a stop arriving from now on
/// is not reported as one: every output is in place and the process is
/// about to exit with the work's own status. Returns false if a stop began
/// first (the caller then leaves the exit to it).
pub fn finish() -> bool {
    STATE.finish()
}

/// A child process writing a listed temporary (FFmpeg encoding a video),
/// listed for as long as the guard lives: a stop kills it before removing
/// the files, so that it cannot make its output again after the removal
/// (it opens its output some milliseconds after it starts).
#[derive(Debug)]
pub struct ChildInFlight {
    id: u64,
}

impl ChildInFlight {
    pub fn new(pid: u32) -> ChildInFlight {
        ChildInFlight {
            id: CHILDREN.add(pid),
        }
    }
}

impl Drop for ChildInFlight {
    fn drop(&mut self) {
        CHILDREN.remove(self.id);
    }
}

/// A scratch folder (removed when dropped) listed, so that a stop removes
/// it too; made inside a [`guarded`] step, so a stop never falls between
/// its making and its listing.
pub struct ListedTempDir {
    dir: tempfile::TempDir,
    _listed: InFlight,
}

impl ListedTempDir {
    /// A new folder in the system's temporary folder.
    pub fn new() -> std::io::Result<ListedTempDir> {
        guarded(|| {
            let dir = tempfile::tempdir()?;
            let _listed = InFlight::new(dir.path());
            Ok(ListedTempDir { dir, _listed })
        })
    }

    pub fn path(&self) -> &Path {
        self.dir.path()
    }
}

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
        InFlight {
            id: IN_FLIGHT.add(path.to_path_buf()),
        }
    }
}

impl Drop for InFlight {
    fn drop(&mut self) {
        IN_FLIGHT.remove(self.id);
    }
}

/// Begins a stop: waits for the [`guarded`] step in progress, keeps any
/// other from starting, kills the listed child processes (and waits for
/// them), then removes every listed temporary (files, and folders with
/// their content); returns the paths removed, the most recently listed
/// first. The process must end right after: the writers are not told,
/// and their next guarded step never returns. `None`, doing nothing, once
/// the work has [`finish`]ed: the stop came too late to stop anything.
pub fn remove_in_flight() -> Option<Vec<PathBuf>> {
    if !STATE.begin_stop() {
        return None;
    }
    std::mem::forget(GATE.write().unwrap_or_else(|e| e.into_inner()));
    for (_, pid) in CHILDREN.lock().drain(..) {
        // SAFETY: kill and waitpid on a child of this process; the pid
        // cannot have been reused: its owner takes it off the list before
        // it reaps it, and the list is emptied here.
        unsafe {
            libc::kill(pid as libc::pid_t, libc::SIGKILL);
            libc::waitpid(pid as libc::pid_t, std::ptr::null_mut(), 0);
        }
    }
    let mut removed = remove_where(|_| true);
    removed.reverse();
    Some(removed)
}

/// [`remove_in_flight`] for the listed paths `pick` selects.
fn remove_where(pick: impl Fn(&Path) -> bool) -> Vec<PathBuf> {
    let listed: Vec<PathBuf> = {
        let mut all = IN_FLIGHT.lock();
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
        assert!(!IN_FLIGHT
            .lock()
            .iter()
            .any(|(_, p)| p.starts_with(d.path())));
    }

    /// Whichever comes first of a stop and the work's end wins, for good.
    /// (A state of its own: the process's is left to the process.)
    #[test]
    fn a_stop_after_the_work_finished_stops_nothing_and_the_other_way_round() {
        let s = RunState::new();
        assert!(s.finish(), "nothing had stopped the work");
        assert!(s.finish(), "finishing twice is still finished");
        assert!(!s.begin_stop(), "a late stop stops nothing");
        assert!(!s.stopping());
        let s = RunState::new();
        assert!(s.begin_stop() && s.stopping());
        assert!(s.begin_stop(), "a second signal goes on with the stop");
        assert!(!s.finish(), "a stop that began first keeps the exit");
        assert!(s.stopping());
    }
}
