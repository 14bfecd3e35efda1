//! Stage 6 for a whole dataset: the config's `[render]` settings become the
//! renderer's parameters, and every session (or one shard's) is rendered
//! with progress reported in frames.

use crate::progress::{Progress, Stage};
use crate::shard::Shard;
use crate::{Error, Result};
use eyereplay_dataset::RenderSettings;
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

/// What a dataset render did.
#[derive(Clone, Debug, Default)]
pub struct RenderSummary {
    pub rendered: usize,
    pub skipped: usize,
    pub frames: usize,
    pub clamped_points: usize,
}

/// Renders the sessions of `out` (this shard's only, with `shard`); fails
/// listing the sessions that failed after the others are written.
pub fn render_sessions(
    out: &Path,
    dataset_seed: u64,
    settings: &RenderSettings,
    params: RenderParams,
    session_frames: usize,
    shard: Option<Shard>,
    progress: &dyn Progress,
) -> Result<RenderSummary> {
    let labels = eyereplay_dataset::read_labels(out)?;
    let sessions = shard.map_or(labels.len(), |s| s.count_of(labels.len()));
    progress.begin(Stage::Render, (sessions * session_frames) as u64);
    let done = AtomicUsize::new(0);
    let opts = DatasetOptions {
        dataset_seed,
        jobs: settings.jobs(),
        params,
        natural_blinks: settings.natural_blinks,
        shard: shard.map(|s| (s.index, s.count)),
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
