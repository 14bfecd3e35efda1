//! A request to stop long work, for callers that cannot end the process:
//! the Python package, where Ctrl-C (or a notebook's interrupt) must
//! raise `KeyboardInterrupt` in the middle of a render or an extraction
//! and leave the interpreter running.
//!
//! The work checks [`check`] once per frame it draws, encodes or reads
//! (an atomic load), and returns [`CoreError::Stopped`]; the usual error
//! paths then remove what it was writing. The flag is one per process:
//! a stop asked for by one caller stops the work of every thread.
//! The command line does not use it (a stop ends the process there).

use crate::CoreError;
use std::sync::atomic::{AtomicBool, Ordering};

static REQUESTED: AtomicBool = AtomicBool::new(false);

/// Asks all running work to stop at its next frame.
pub fn request() {
    REQUESTED.store(true, Ordering::SeqCst);
}

/// Lets work run again, once the work asked to stop has returned.
pub fn clear() {
    REQUESTED.store(false, Ordering::SeqCst);
}

/// Whether a stop has been requested (and not yet cleared).
pub fn requested() -> bool {
    REQUESTED.load(Ordering::Relaxed)
}

/// `Err(CoreError::Stopped)` once a stop has been requested.
pub fn check() -> Result<(), CoreError> {
    if requested() {
        Err(CoreError::Stopped)
    } else {
        Ok(())
    }
}
