//! Stage 6 for a whole dataset: the config's `[render]` settings become the
//! renderer's parameters, and every session (or one shard's) is rendered
//! with progress reported in frames.

use crate::progress::{Progress, Stage};
use crate::shard::Shard;
use crate::{Error, Result};
use eyereplay_browser::{BrowserJob, BrowserSettings};
use eyereplay_dataset::{DatasetMetadata, RenderBackend, RenderSettings, SessionIdentity};
use eyereplay_prepare::DatasetConfig;
use eyereplay_render::{render_dataset, DatasetOptions, RenderParams, SessionOutcome};
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};

/// The renderer's parameters from a config's `[render]` settings (video
/// size defaults to the canvas; fps, canvas and calibration come from the
/// dataset when it is rendered).
pub fn render_params(settings: &RenderSettings, cfg: &DatasetConfig) -> Result<RenderParams> {
    let mut p = RenderParams::new(eyereplay_render::Identity::sample(0));
    p.width = settings.width.unwrap_or(cfg.canvas.width_px as usize);
    p.height = settings.height.unwrap_or(cfg.canvas.height_px as usize);
    p.fps = cfg.fps;
    p.mapping = eyereplay_render::GazeMapping::new(cfg.canvas);
    p.mapping.gain = settings.gain;
    p.mapping.viewing_distance_mm = settings.viewing_distance_mm;
    p.natural_blinks = settings.natural_blinks;
    p.encoder.preset = settings.preset.clone();
    p.encoder.crf = settings.crf;
    p.validate()
        .map_err(|e| Error::Setting(format!("[render]: {e}")))?;
    Ok(p)
}

/// Opens one session of a backend that renders sessions one by one (face,
/// replay): removes leftover temporary files of its outputs (`extra`, the
/// backend's own extra file, among them), and reads its trajectory; `None`
/// when the session is already complete (`extra` exists and the video has
/// every frame).
pub(crate) fn open_session(
    job: &eyereplay_render::SessionJob,
    extra: &Path,
    ffprobe: &Path,
) -> Result<Option<Vec<eyereplay_core::CanvasPos>>> {
    let files = &job.paths;
    for target in files.outputs() {
        for p in eyereplay_core::stale_temp_files(&target) {
            std::fs::remove_file(&p).map_err(|e| Error::io(&p, e))?;
        }
    }
    let traj = eyereplay_core::read_session_csv(&files.csv)?;
    if extra.exists() && eyereplay_render::is_complete(job, traj.len(), ffprobe) {
        return Ok(None);
    }
    Ok(Some(traj))
}

/// What a dataset render did.
#[derive(Clone, Debug, Default)]
pub struct RenderSummary {
    pub rendered: usize,
    pub skipped: usize,
    pub frames: usize,
    pub clamped_points: usize,
}

/// The `[render.browser]` table, typed; `None` unless the backend is
/// `browser`. Also finds the browser, so a missing one is reported before
/// work starts (one line naming the Debian package).
pub fn browser_settings(settings: &RenderSettings) -> Result<Option<BrowserSettings>> {
    if settings.backend != RenderBackend::Browser {
        return Ok(None);
    }
    let table = settings.browser.clone().unwrap_or_default();
    let b: BrowserSettings = toml::Value::Table(table)
        .try_into()
        .map_err(|e| Error::Setting(format!("[render.browser]: {}", e.message())))?;
    eyereplay_browser::find_browser(b.browser.as_deref())
        .map_err(|e| Error::Setting(e.to_string()))?;
    Ok(Some(b))
}

/// Renders the sessions of `out` (this shard's only, with `shard`) with the
/// configured backend; fails listing the sessions that failed after the
/// others are written.
pub fn render_sessions(
    out: &Path,
    settings: &RenderSettings,
    params: RenderParams,
    shard: Option<Shard>,
    progress: &dyn Progress,
) -> Result<RenderSummary> {
    // Seed, frame rate and session length are the dataset's own.
    let meta = eyereplay_dataset::read_metadata(out)?.dataset;
    if settings.backend == RenderBackend::Face {
        return crate::face::render_sessions_face(out, &meta, settings, &params, shard, progress);
    }
    if settings.backend == RenderBackend::Replay {
        return crate::replay::render_sessions_replay(
            out, &meta, settings, &params, shard, progress,
        );
    }
    match browser_settings(settings)? {
        Some(b) => render_sessions_browser(out, &meta, settings, &b, &params, shard, progress),
        None => render_sessions_eyes(out, &meta, settings, params, shard, progress),
    }
}

/// Our own renderer, every session in parallel.
fn render_sessions_eyes(
    out: &Path,
    meta: &DatasetMetadata,
    settings: &RenderSettings,
    params: RenderParams,
    shard: Option<Shard>,
    progress: &dyn Progress,
) -> Result<RenderSummary> {
    let session_frames = meta.session_frames;
    let labels = eyereplay_dataset::read_labels(out)?;
    let sessions = shard.map_or(labels.len(), |s| s.count_of(labels.len()));
    progress.begin(Stage::Render, (sessions * session_frames) as u64);
    let done = AtomicUsize::new(0);
    let opts = DatasetOptions {
        dataset_seed: meta.seed,
        jobs: settings.jobs(),
        params,
        natural_blinks: settings.natural_blinks,
        shard: shard.map(|s| (s.index, s.count)),
        response: crate::match_extractor_probe(
            settings.match_extractor,
            settings.extractor_iris_views,
        )?,
    };
    let summary = render_dataset(out, &opts, &|job, outcome| {
        let n = done.fetch_add(1, Ordering::Relaxed) + 1;
        progress.status(&format!("{n}/{sessions} sessions"));
        progress.advance(session_frames as u64);
        if let SessionOutcome::Failed(m) = outcome {
            progress.warn(&format!("error: {}: {m}", job.paths.file));
        }
    })?;
    progress.end(Stage::Render);
    if !summary.failed.is_empty() {
        return Err(Error::SessionsFailed(summary.failed));
    }
    Ok(RenderSummary {
        rendered: summary.rendered,
        skipped: summary.skipped,
        frames: summary.frames,
        clamped_points: summary.clamped_points,
    })
}

/// The browser backend: each unfinished session's trajectory driven through
/// the page frame by frame, `jobs` browsers at a time; beside each video the
/// truth CSV (cursor per frame, plus the page's own truth columns) and an
/// identity file naming the page (and its eyes, when configured).
fn render_sessions_browser(
    out: &Path,
    meta: &DatasetMetadata,
    settings: &RenderSettings,
    browser: &BrowserSettings,
    params: &RenderParams,
    shard: Option<Shard>,
    progress: &dyn Progress,
) -> Result<RenderSummary> {
    let ffprobe = eyereplay_render::ffprobe_for(&params.encoder.ffmpeg);
    let sessions = shard_sessions(out, meta.seed, shard)?;
    let mut summary = RenderSummary::default();
    let mut todo = Vec::new();
    for job in sessions {
        for target in job.paths.outputs() {
            for p in eyereplay_core::stale_temp_files(&target) {
                std::fs::remove_file(&p).map_err(|e| Error::io(&p, e))?;
            }
        }
        let trajectory = eyereplay_core::read_session_csv(&job.paths.csv)?;
        if eyereplay_render::is_complete(&job, trajectory.len(), &ffprobe) {
            summary.skipped += 1;
            continue;
        }
        todo.push((job, trajectory));
    }
    let total: usize = todo.iter().map(|(_, t)| t.len()).sum();
    progress.begin(Stage::Render, total as u64);
    let jobs = if settings.jobs > 0 {
        settings.jobs
    } else {
        std::thread::available_parallelism().map_or(1, |n| (n.get() / 2).max(1))
    };
    let mut failed = Vec::new();
    // A batch of `jobs` sessions at a time, so progress moves per batch.
    for batch in todo.chunks(jobs) {
        let browser_jobs: Vec<BrowserJob> = batch
            .iter()
            .map(|(job, t)| BrowserJob {
                trajectory: t.clone(),
                fps: meta.fps,
                out_mp4: job.paths.mp4.clone(),
                out_truth_csv: job.paths.truth.clone(),
            })
            .collect();
        let results =
            eyereplay_browser::render_sessions(browser, &params.encoder, &browser_jobs, jobs);
        for ((job, t), r) in batch.iter().zip(results) {
            progress.advance(t.len() as u64);
            match r {
                Ok(stats) => {
                    SessionIdentity {
                        file: job.paths.file.clone(),
                        seed: job.seed,
                        identity: serde_json::json!({ "backend": "browser", "url": browser.url }),
                        mapping: &browser.mapping,
                        width: stats.width,
                        height: stats.height,
                        fps: meta.fps,
                        eyes: settings
                            .browser_eye_corners_px
                            .map(SessionIdentity::eyes_from_corners),
                        extractor_iris_views: None,
                    }
                    .write(&job.paths.identity_json)?;
                    summary.add(stats.frames, stats.clamped_points);
                }
                Err(e) => fail(&mut failed, &job.paths.file, &e, progress),
            }
        }
    }
    finish(summary, failed, progress)
}

/// The sessions of `out` in labels.csv order, this shard's only.
pub(crate) fn shard_sessions(
    out: &Path,
    seed: u64,
    shard: Option<Shard>,
) -> Result<Vec<eyereplay_render::SessionJob>> {
    let sessions = eyereplay_render::list_sessions(out, seed)?;
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

impl RenderSummary {
    /// Counts one rendered session.
    pub(crate) fn add(&mut self, frames: usize, clamped_points: usize) {
        self.rendered += 1;
        self.frames += frames;
        self.clamped_points += clamped_points;
    }
}

/// Reports a failed session and keeps its message for the final error.
pub(crate) fn fail(
    failed: &mut Vec<String>,
    file: &str,
    e: &dyn std::fmt::Display,
    progress: &dyn Progress,
) {
    let m = format!("{file}: {e}");
    progress.warn(&format!("error: {m}"));
    failed.push(m);
}

/// Ends the render stage: the summary, or every failure in one error (the
/// other sessions are written).
pub(crate) fn finish(
    summary: RenderSummary,
    failed: Vec<String>,
    progress: &dyn Progress,
) -> Result<RenderSummary> {
    progress.end(Stage::Render);
    if !failed.is_empty() {
        return Err(Error::SessionsFailed(failed));
    }
    Ok(summary)
}
