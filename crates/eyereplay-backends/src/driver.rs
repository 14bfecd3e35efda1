//! The one driver every backend runs under: lists the dataset's sessions
//! (one shard's, with a [`Shard`]), removes what a killed run left, skips
//! sessions already whole, draws the rest `parallel_sessions` at a time,
//! commits each session's files together, and reports every failure after
//! the other sessions are written.

use crate::backend::{Rendered, Session, SessionBackend, SessionOutputs};
use crate::{BackendError, Result};
use eyereplay_core::{Progress, Shard, Stage};
use eyereplay_render::{list_sessions, SessionJob};
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

/// What a dataset render did.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct RenderSummary {
    pub rendered: usize,
    pub skipped: usize,
    pub frames: usize,
    pub clamped_points: usize,
}

/// True when the session's video has as many frames as its CSV has rows
/// and its truth and identity files are there. The frames are counted in
/// this process (`count_video_packets`), not by an `ffprobe` per session,
/// whose start alone cost about 0.15 CPU-s; a video that cannot be read
/// is not complete, and its session is drawn again.
pub fn is_complete(job: &SessionJob, frames: usize) -> bool {
    why_incomplete(job, frames).is_none()
}

/// What keeps a session from being whole, naming the file: its video
/// missing or of other than `frames` frames, its truth file short or
/// missing, its identity file missing; `None` when it is whole.
pub fn why_incomplete(job: &SessionJob, frames: usize) -> Option<(PathBuf, String)> {
    let p = &job.paths;
    let video = if p.mp4.exists() {
        match eyereplay_extract::count_video_packets(&p.mp4) {
            Ok(n) if n == frames as u64 => None,
            Ok(n) => Some(format!("{n} of {frames} frames")),
            Err(_) => Some("not a readable video".to_string()),
        }
    } else {
        Some("missing".to_string())
    };
    if let Some(why) = video {
        return Some((p.mp4.clone(), why));
    }
    match csv_data_rows(&p.truth) {
        None => return Some((p.truth.clone(), "missing".into())),
        Some(n) if n != frames => return Some((p.truth.clone(), format!("{n} of {frames} rows"))),
        Some(_) => {}
    }
    if !p.identity_json.exists() {
        return Some((p.identity_json.clone(), "missing".into()));
    }
    // Damaged (a copy cut short, a hand edit): drawn again on resume, as
    // a video cut short is; it was found only after the other sessions'
    // drawing, by what reads it.
    if eyereplay_dataset::SessionIdentity::read(&p.identity_json).is_err() {
        return Some((p.identity_json.clone(), "not readable".into()));
    }
    None
}

/// Data rows of a CSV with one header line (a last line without its
/// newline counted); `None` when it cannot be read.
pub fn csv_data_rows(path: &Path) -> Option<usize> {
    let bytes = std::fs::read(path).ok()?;
    let lines = bytes
        .split(|b| *b == b'\n')
        .filter(|l| !l.is_empty() && *l != b"\r")
        .count();
    Some(lines.saturating_sub(1))
}

/// The sessions of `out` in labels.csv order, this shard's only.
pub fn shard_sessions(out: &Path, seed: u64, shard: Option<Shard>) -> Result<Vec<SessionJob>> {
    let sessions = list_sessions(out, seed)?;
    Ok(match shard {
        None => sessions,
        Some(s) => sessions
            .into_iter()
            .enumerate()
            .filter(|(i, _)| s.contains(*i))
            .map(|(_, j)| j)
            .collect(),
    })
}

/// A session to draw, its files read.
struct Todo {
    job: SessionJob,
    trajectory: Vec<eyereplay_core::CanvasPos>,
    blinks: Option<Vec<bool>>,
    extra: Vec<PathBuf>,
}

/// One render of a dataset's sessions (or of one shard's) at a time: a
/// second run over the same folder would draw every session again and
/// remove the first's half-written files under it. An exclusive lock on a
/// hidden file of the dataset, per shard (shards of one dataset draw side
/// by side), released when the run ends however it ends (the OS drops it
/// with the process); the file is removed after a run.
struct RenderLock {
    /// None where the folder cannot be written: a finished dataset on a
    /// read-only disk is still checked, and one with sessions to draw
    /// fails on its first file as before.
    held: Option<(std::fs::File, std::path::PathBuf)>,
    /// The lock file, for the binary's Ctrl-C handler to remove.
    _listed: Option<eyereplay_core::inflight::InFlight>,
}

impl RenderLock {
    fn take(out: &Path, shard: Option<Shard>, progress: &dyn Progress) -> Result<RenderLock> {
        // Shards counted from 0, as `--shard K/N` counts them.
        let name = match shard {
            Some(s) => format!(".eyereplay-render.shard-{}-of-{}.lock", s.index, s.count),
            None => ".eyereplay-render.lock".to_string(),
        };
        let path = out.join(name);
        let opened = std::fs::OpenOptions::new()
            .create(true)
            .truncate(false)
            .read(true)
            .write(true)
            .open(&path);
        let mut file = match opened {
            Ok(f) => f,
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::PermissionDenied | std::io::ErrorKind::ReadOnlyFilesystem
                ) =>
            {
                return Ok(RenderLock {
                    held: None,
                    _listed: None,
                });
            }
            Err(e) => return Err(BackendError::io(&path, e)),
        };
        match file.try_lock() {
            Ok(()) => {}
            Err(std::fs::TryLockError::WouldBlock) => {
                let mut holder = String::new();
                let _ = std::io::Read::read_to_string(&mut file, &mut holder);
                return Err(BackendError::input(
                    out,
                    format!(
                        "another eyereplay run is drawing this dataset{} ({}); wait for it to end, or stop it",
                        shard.map_or(String::new(), |s| format!("'s shard {}/{}", s.index, s.count)),
                        holder.trim()
                    ),
                ));
            }
            // A file system without flock (Lustre mounted without `-o
            // flock`, some NFS setups): the lock only keeps a second run of
            // one shard from drawing beside the first, so draw without it
            // and say so, rather than refuse every shard.
            Err(std::fs::TryLockError::Error(e)) if e.kind() == std::io::ErrorKind::Unsupported => {
                progress.info(&format!(
                    "warning: {}: this file system cannot lock files ({e}); nothing keeps a second run of this {} from drawing beside this one",
                    path.display(),
                    if shard.is_some() { "shard" } else { "dataset" }
                ));
                let _ = std::fs::remove_file(&path);
                return Ok(RenderLock {
                    held: None,
                    _listed: None,
                });
            }
            Err(std::fs::TryLockError::Error(e)) => return Err(BackendError::io(&path, e)),
        }
        // Who holds it, for the message of a run that finds it held.
        let me = format!("pid {}", std::process::id());
        file.set_len(0)
            .and_then(|()| std::io::Write::write_all(&mut file, me.as_bytes()))
            .map_err(|e| BackendError::io(&path, e))?;
        Ok(RenderLock {
            _listed: Some(eyereplay_core::inflight::InFlight::new(&path)),
            held: Some((file, path)),
        })
    }
}

impl Drop for RenderLock {
    fn drop(&mut self) {
        if let Some((file, path)) = &self.held {
            // Removed while still held, so no other run can be holding it.
            let _ = std::fs::remove_file(path);
            let _ = file.unlock();
        }
    }
}

/// Renders the unfinished sessions of the dataset in `out` (this shard's
/// only) with `backend`; fails listing the sessions that failed after the
/// others are written.
pub fn render_dataset(
    out: &Path,
    backend: &dyn SessionBackend,
    shard: Option<Shard>,
    progress: &dyn Progress,
) -> Result<RenderSummary> {
    let meta = eyereplay_dataset::read_metadata(out)?.dataset;
    let _lock = RenderLock::take(out, shard, progress)?;
    let mut summary = RenderSummary::default();
    let mut todo = Vec::new();
    // Every trajectory is read before any session is drawn: one that
    // cannot be read stops the job before hours of drawing, not after.
    let mut unreadable = Vec::new();
    let mut failed = Vec::new();
    // Each session checked on its own (its files only), all of them at
    // once: a resumed run of thousands of sessions reads every finished
    // video through (`is_complete`), some milliseconds each. The results
    // are then taken in labels.csv order.
    let checked: Vec<Result<(SessionJob, _, Vec<_>, bool)>> =
        shard_sessions(out, meta.seed, shard)?
            .into_par_iter()
            .map(|job| {
                let extra = backend.extra_outputs(&job.paths);
                // Leftovers of an interrupted render of this session only:
                // other shards may be writing theirs.
                for p in SessionOutputs::leftovers(&job.paths, &extra) {
                    std::fs::remove_file(&p).map_err(|e| BackendError::io(&p, e))?;
                }
                // The trajectory and its blink column, each error naming
                // the session's file.
                let trajectory = eyereplay_core::read_session_csv(&job.paths.csv)
                    .map_err(|e| e.to_string())
                    .and_then(|t| {
                        eyereplay_dataset::check_session_rows(
                            &job.paths.csv,
                            t.len(),
                            meta.session_frames,
                        )
                        .map(|()| t)
                        .map_err(|e| e.to_string())
                    })
                    .and_then(|t| {
                        eyereplay_dataset::read_blink_column(&job.paths.csv)
                            .map(|blinks| (t, blinks))
                            .map_err(|e| e.to_string())
                    });
                let complete = match &trajectory {
                    // The backend's own files hold a row per frame, as
                    // the truth file does: one cut short is redrawn.
                    Ok((t, _)) => {
                        extra.iter().all(|p| csv_data_rows(p) == Some(t.len()))
                            && is_complete(&job, t.len())
                    }
                    Err(_) => false,
                };
                Ok((job, trajectory, extra, complete))
            })
            .collect();
    for item in checked {
        let (job, trajectory, extra, complete) = item?;
        let (trajectory, blinks) = match trajectory {
            Ok(read) => read,
            Err(e) => {
                unreadable.push(e);
                continue;
            }
        };
        if complete {
            summary.skipped += 1;
            continue;
        }
        todo.push(Todo {
            job,
            trajectory,
            blinks,
            extra,
        });
    }
    if !unreadable.is_empty() {
        return Err(BackendError::UnreadableSessions(unreadable));
    }
    let total_frames: usize = todo.iter().map(|t| t.trajectory.len()).sum();
    progress.begin(Stage::Render, total_frames as u64);
    let sessions = todo.len();
    let done = AtomicUsize::new(0);
    let draw = |t: &Todo| -> Result<Rendered> {
        let session = Session {
            job: &t.job,
            trajectory: t.trajectory.clone(),
            blinks: t.blinks.clone(),
            dataset_seed: meta.seed,
            fps: meta.fps,
        };
        // A stop asked for leaves the sessions not yet started alone.
        eyereplay_core::cancel::check()?;
        let outputs = SessionOutputs::new(&t.job.paths, &t.extra);
        match backend.render(&session, &outputs, progress) {
            Ok(r) => outputs.commit().map(|()| r),
            Err(e) => {
                outputs.discard();
                Err(e)
            }
        }
    };
    let run_one = |item: &Todo| {
        let r = draw(item);
        let n = done.fetch_add(1, Ordering::Relaxed) + 1;
        progress.status(&format!("{n}/{sessions} sessions"));
        progress.advance(item.trajectory.len() as u64);
        if let Err(e) = &r {
            // A stop is not the session's fault. A terminal's Ctrl-C
            // reaches FFmpeg too, whose exit can fail the session before
            // the stop's handler has begun: a failure (rare) waits a
            // moment for it before it is reported.
            std::thread::sleep(std::time::Duration::from_millis(100));
            let stopped =
                eyereplay_core::cancel::requested() || eyereplay_core::inflight::stopping();
            if !stopped {
                progress.warn(&format!("error: {}: {e}", item.job.paths.file));
            }
        }
        r
    };
    // No more workers than sessions to draw: each is a thread with its own
    // buffers (100,000 asked for built threads for minutes).
    let threads = backend.parallel_sessions().clamp(1, todo.len().max(1));
    let results: Vec<Result<Rendered>> = if threads == 1 {
        todo.iter().map(run_one).collect()
    } else {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .map_err(|e| BackendError::Setting(format!("render threads: {e}")))?;
        pool.install(|| todo.par_iter().map(run_one).collect())
    };
    progress.end(Stage::Render);
    for (Todo { job, .. }, r) in todo.iter().zip(results) {
        match r {
            Ok(r) => {
                summary.rendered += 1;
                summary.frames += r.frames;
                summary.clamped_points += r.clamped_points;
            }
            Err(e) => failed.push(format!("{}: {e}", job.paths.file)),
        }
    }
    if !failed.is_empty() {
        return Err(BackendError::SessionsFailed(failed));
    }
    Ok(summary)
}
