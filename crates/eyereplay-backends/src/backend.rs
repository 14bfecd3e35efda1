//! What a render backend is: the [`SessionBackend`] trait, the
//! [`Session`] it is given and the [`SessionOutputs`] it writes into.
//! Everything else (listing, sharding, resume, cleanup, committing, failure
//! collection, progress) is the driver's ([`crate::render_dataset`]).

use crate::{BackendError, Result};
use eyereplay_core::{CanvasPos, Progress};
use eyereplay_dataset::{SessionIdentity, SessionPaths};
use eyereplay_render::SessionJob;
use serde::Serialize;
use std::path::{Path, PathBuf};

/// One session to draw, as the driver read it.
pub struct Session<'a> {
    /// Its files, seed, label and place among its class's sessions.
    pub job: &'a SessionJob,
    /// Canvas position per frame.
    pub trajectory: Vec<CanvasPos>,
    /// Per-frame blink flags of the session CSV, when it has them.
    pub blinks: Option<Vec<bool>>,
    /// The dataset's seed, frame rate and session length.
    pub dataset_seed: u64,
    pub fps: f64,
}

/// What a backend reports of a session it drew.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Rendered {
    pub frames: usize,
    /// Trajectory points outside the drawable range, clamped.
    pub clamped_points: usize,
}

/// The files a session of the backend named `backend` (as
/// `render.backend` spells it) writes besides `mp4`, `truth` and
/// `identity_json`, one row per frame each: the face mode's head CSV, the
/// replay mode's carrier CSV. What [`SessionBackend::extra_outputs`]
/// returns, and what `merge`, which opens no backend, checks.
pub fn extra_outputs_of(backend: &str, paths: &SessionPaths) -> Vec<PathBuf> {
    match backend {
        "face" => vec![paths.head_csv()],
        "replay" => vec![paths.carrier_csv()],
        _ => Vec::new(),
    }
}

/// A render backend: draws one session of a prepared dataset into its
/// files. Implement [`render`](SessionBackend::render) (and
/// [`extra_outputs`](SessionBackend::extra_outputs) when it writes more
/// than the video, the truth CSV and the identity file); the driver does
/// the rest. Work shared by every session (fitting photos, measuring
/// carriers, loading models) is done once when the backend is built.
pub trait SessionBackend: Sync {
    /// As `render.backend` spells it.
    fn name(&self) -> &'static str;
    /// Files of a session besides `mp4`, `truth` and `identity_json` (the
    /// face mode's head CSV, the replay mode's carrier CSV).
    fn extra_outputs(&self, paths: &SessionPaths) -> Vec<PathBuf> {
        extra_outputs_of(self.name(), paths)
    }
    /// Sessions it can draw at once (each call to `render` on its own
    /// thread).
    fn parallel_sessions(&self) -> usize {
        1
    }
    /// Draws `session` into `out`'s files (video, truth CSV, identity and
    /// any extra outputs). The files become the session's only when every
    /// one is written and this returns `Ok`.
    fn render(
        &self,
        session: &Session,
        out: &SessionOutputs,
        progress: &dyn Progress,
    ) -> Result<Rendered>;
}

/// Where a backend writes one session: hidden staging names beside the
/// session's files (same folder, so committing is a rename), committed all
/// together when the session succeeds and removed when it fails, so a
/// session's files are all of one render or absent.
pub struct SessionOutputs {
    paths: SessionPaths,
    /// The backend's [`extra_outputs`](SessionBackend::extra_outputs).
    extra: Vec<PathBuf>,
    /// The staged files, listed for the binary's Ctrl-C handler to remove.
    _listed: Vec<eyereplay_core::inflight::InFlight>,
}

/// The staging name of `target`: hidden, with its extension kept (ffmpeg
/// and the CSV readers go by it).
fn staged(target: &Path) -> PathBuf {
    let name = target.file_name().unwrap_or_default().to_string_lossy();
    target.with_file_name(format!(".staged.{name}"))
}

impl SessionOutputs {
    pub(crate) fn new(paths: &SessionPaths, extra: &[PathBuf]) -> SessionOutputs {
        let mut outputs = SessionOutputs {
            paths: paths.clone(),
            extra: extra.to_vec(),
            _listed: Vec::new(),
        };
        outputs._listed = outputs
            .finals()
            .map(|f| eyereplay_core::inflight::InFlight::new(&staged(f)))
            .collect();
        outputs
    }

    /// The session's files in the order they are committed: the video
    /// last.
    fn finals(&self) -> impl Iterator<Item = &PathBuf> {
        self.extra.iter().chain([
            &self.paths.truth,
            &self.paths.identity_json,
            &self.paths.mp4,
        ])
    }

    /// Every final path's staging name, and the temporary files a killed
    /// run may have left of either.
    pub(crate) fn leftovers(paths: &SessionPaths, extra: &[PathBuf]) -> Vec<PathBuf> {
        let mut v = Vec::new();
        for f in Self::new(paths, extra).finals() {
            let s = staged(f);
            v.extend(eyereplay_core::stale_temp_files(f));
            v.extend(eyereplay_core::stale_temp_files(&s));
            if s.exists() {
                v.push(s);
            }
        }
        v
    }

    /// Where to write the session's video.
    pub fn mp4(&self) -> PathBuf {
        staged(&self.paths.mp4)
    }

    /// Where to write the session's per-frame truth CSV.
    pub fn truth(&self) -> PathBuf {
        staged(&self.paths.truth)
    }

    /// Where to write `target`, one of the backend's
    /// [`extra_outputs`](SessionBackend::extra_outputs).
    pub fn extra(&self, target: &Path) -> PathBuf {
        debug_assert!(
            self.extra.iter().any(|e| e == target),
            "{} is not an extra output",
            target.display()
        );
        staged(target)
    }

    /// Writes the session's identity file.
    pub fn write_identity<I: Serialize, M: Serialize>(
        &self,
        identity: &SessionIdentity<I, M>,
    ) -> Result<()> {
        identity.write(&staged(&self.paths.identity_json))?;
        Ok(())
    }

    /// Makes the staged files the session's: every one must exist; the
    /// video is renamed last, so a session whose video is in place is
    /// whole.
    pub(crate) fn commit(self) -> Result<()> {
        // A stop (Ctrl-C) finds the session's files all staged or all in
        // place.
        eyereplay_core::inflight::guarded(|| self.commit_unguarded())
    }

    fn commit_unguarded(self) -> Result<()> {
        if let Some(f) = self.finals().find(|f| !staged(f).is_file()) {
            let e = BackendError::input(staged(f), "the backend did not write this output");
            self.discard();
            return Err(e);
        }
        for f in self.finals() {
            if let Err(e) = std::fs::rename(staged(f), f) {
                let e = BackendError::io(f, e);
                self.discard();
                return Err(e);
            }
        }
        Ok(())
    }

    /// Removes whatever was staged.
    pub(crate) fn discard(&self) {
        // Guarded as the encoder's cleanup is: a session failed by a stop
        // leaves its files to the stop, which removes and reports them.
        eyereplay_core::inflight::guarded(|| {
            for f in self.finals() {
                let _ = std::fs::remove_file(staged(f));
            }
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn paths(dir: &Path) -> SessionPaths {
        SessionPaths::beside_video(&dir.join("reading/reading_0000.mp4"))
    }

    #[test]
    fn a_session_is_committed_whole_or_not_at_all() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir_all(dir.path().join("reading")).unwrap();
        let p = paths(dir.path());
        let extra = [p.head_csv()];
        let out = SessionOutputs::new(&p, &extra);
        // Staged names are hidden, beside their targets, extension kept.
        assert_eq!(
            out.mp4(),
            dir.path().join("reading/.staged.reading_0000.mp4")
        );
        for f in [out.mp4(), out.truth(), out.extra(&extra[0])] {
            std::fs::write(f, b"x").unwrap();
        }
        // The identity file is missing: nothing is committed, nothing left.
        assert!(out.commit().is_err());
        for f in [&p.mp4, &p.truth, &p.identity_json, &extra[0]] {
            assert!(!f.exists(), "{}", f.display());
        }
        assert!(SessionOutputs::leftovers(&p, &extra).is_empty());
        let out = SessionOutputs::new(&p, &extra);
        for f in [out.mp4(), out.truth(), out.extra(&extra[0])] {
            std::fs::write(f, b"x").unwrap();
        }
        let id: SessionIdentity = SessionIdentity {
            file: "reading/reading_0000.csv".into(),
            seed: 1,
            identity: serde_json::json!({}),
            mapping: serde_json::json!({}),
            width: 2,
            height: 2,
            fps: 25.0,
            eyes: None,
            extractor_iris_views: None,
        };
        out.write_identity(&id).unwrap();
        out.commit().unwrap();
        for f in [&p.mp4, &p.truth, &p.identity_json, &extra[0]] {
            assert!(f.is_file(), "{}", f.display());
        }
        assert!(SessionOutputs::leftovers(&p, &extra).is_empty());
    }
}
