//! # eyereplay-backends
//!
//! Stage 6 for a whole dataset. A render backend draws one session into
//! its files ([`SessionBackend`]); one driver ([`render_dataset`]) lists
//! the sessions, shards, resumes, cleans up after killed runs, commits
//! each session's files together and collects failures, for every
//! backend alike. One module per backend:
//!
//! | `render.backend` | module | draws |
//! |---|---|---|
//! | `eyes` (default) | [`eyes`] | eyereplay's ray-traced close-up of two eyes |
//! | `browser` | `browser` (feature `browser`) | a web page in headless Chromium |
//! | `face` | [`face`] | a whole face from a photo in a webcam frame |
//! | `replay` | [`replay`] | a real person's video, irises redrawn |
//!
//! Adding a backend: a module implementing [`SessionBackend`], a variant
//! of [`BackendSettings`] for its keys, and its arm in [`open_backend`]
//! and [`check_settings`].

mod backend;
#[cfg(feature = "browser")]
pub mod browser;
mod driver;
mod error;
pub mod eyes;
pub mod face;
mod probe;
pub mod replay;
pub mod source_head;

pub use backend::{extra_outputs_of, Rendered, Session, SessionBackend, SessionOutputs};
pub use driver::{
    csv_data_rows, is_complete, render_dataset, shard_sessions, why_incomplete, RenderSummary,
};
pub use error::{BackendError, Result};
pub use probe::{measure_response, ResponseProbe};

use eyereplay_core::Progress;
use eyereplay_dataset::{BackendSettings, RenderSettings};
use eyereplay_prepare::DatasetConfig;
use eyereplay_render::RenderParams;
use std::path::Path;

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
    // The frame rate is the dataset's (top level), not the [render] table's.
    if !(cfg.fps.is_finite() && cfg.fps > 0.0 && cfg.fps <= 1000.0) {
        return Err(BackendError::Setting(format!(
            "fps = {}: the dataset's frame rate must be above 0 and at most 1000",
            cfg.fps
        )));
    }
    check_ranges(settings)?;
    p.validate()
        .map_err(|e| BackendError::Setting(format!("[render]: {e}")))?;
    Ok(p)
}

/// The [render] table's numbers with fixed ranges, checked by
/// [`render_params`] (so `prepare` refuses them too) and again by
/// [`check_settings`].
fn check_ranges(settings: &RenderSettings) -> Result<()> {
    let views = settings
        .backend
        .extractor()
        .map_or(1, |e| e.extractor_iris_views);
    if !(1..=eyereplay_extract::MAX_IRIS_VIEWS).contains(&views) {
        return Err(BackendError::Setting(format!(
            "[render]: extractor_iris_views {views} must be between 1 and {}",
            eyereplay_extract::MAX_IRIS_VIEWS
        )));
    }
    if settings.jobs > eyereplay_dataset::MAX_JOBS {
        return Err(BackendError::Setting(format!(
            "[render]: jobs {} must be at most {} (sessions drawn at once; 0: one per core)",
            settings.jobs,
            eyereplay_dataset::MAX_JOBS
        )));
    }
    if let BackendSettings::Face(f) = &settings.backend {
        let max = eyereplay_dataset::MAX_MATCH_READBACK_EVERY;
        if !(1..=max).contains(&f.match_readback_every) {
            return Err(BackendError::Setting(format!(
                "[render]: match_readback_every {} must be between 1 and {max}",
                f.match_readback_every
            )));
        }
    }
    Ok(())
}

/// Checks the backend's own settings before any work starts, with the
/// paths in them resolved by `resolve` (against the config's folder):
/// the browser found, photos fitted, carriers measured (cached in
/// `cache`). Returns the settings with those paths resolved.
pub fn check_settings(
    settings: &RenderSettings,
    resolve: &dyn Fn(&Path) -> std::path::PathBuf,
    cache: &Path,
) -> Result<RenderSettings> {
    check_ranges(settings)?;
    let mut checked = settings.clone();
    match &mut checked.backend {
        BackendSettings::Eyes { .. } => {}
        #[cfg(feature = "browser")]
        BackendSettings::Browser { browser, .. } => {
            browser::BrowserBackend::settings(browser.as_ref())?;
        }
        #[cfg(not(feature = "browser"))]
        BackendSettings::Browser { .. } => return Err(not_built("browser")),
        BackendSettings::Face(f) => face::check(f, resolve)?,
        BackendSettings::Replay { carriers } => {
            let videos = replay::carrier_videos(carriers, resolve);
            replay::prepare_carriers(&videos, cache, &eyereplay_core::NoProgress)?;
            *carriers = videos;
        }
    }
    Ok(checked)
}

#[cfg(not(feature = "browser"))]
fn not_built(backend: &str) -> BackendError {
    BackendError::Setting(format!(
        "[render]: backend = \"{backend}\" is not in this build (cargo feature \"{backend}\")"
    ))
}

/// The backend `settings` choose, ready to draw the sessions of the
/// dataset in `out` (work shared by its sessions done now).
pub fn open_backend(
    out: &Path,
    settings: &RenderSettings,
    params: RenderParams,
    cache: &Path,
    progress: &dyn Progress,
) -> Result<Box<dyn SessionBackend>> {
    Ok(match &settings.backend {
        BackendSettings::Eyes { extractor } => {
            let probe =
                ResponseProbe::when(extractor.match_extractor, extractor.extractor_iris_views)?;
            let info = eyereplay_render::read_dataset_info(out)?;
            Box::new(eyes::EyesBackend::new(params, info, settings.jobs(), probe))
        }
        #[cfg(feature = "browser")]
        BackendSettings::Browser {
            browser,
            eye_corners_px,
        } => Box::new(browser::BrowserBackend::new(
            browser::BrowserBackend::settings(browser.as_ref())?,
            params.encoder,
            *eye_corners_px,
            settings.sessions_at_once(),
        )),
        #[cfg(not(feature = "browser"))]
        BackendSettings::Browser { .. } => return Err(not_built("browser")),
        BackendSettings::Face(f) => Box::new(face::FaceBackend::new(
            out,
            f,
            &params,
            settings.natural_blinks,
            settings.jobs(),
        )?),
        BackendSettings::Replay { carriers } => {
            let videos = replay::carrier_videos(carriers, |p| p.to_path_buf());
            Box::new(replay::ReplayBackend::new(
                out, &videos, &params, cache, progress,
            )?)
        }
    })
}

/// Renders the sessions of the dataset in `out` (this shard's only) with
/// the backend `settings` choose: [`open_backend`] then
/// [`render_dataset`].
pub fn render_sessions(
    out: &Path,
    settings: &RenderSettings,
    params: RenderParams,
    shard: Option<eyereplay_core::Shard>,
    cache: &Path,
    progress: &dyn Progress,
) -> Result<RenderSummary> {
    let backend = open_backend(out, settings, params, cache, progress)?;
    render_dataset(out, backend.as_ref(), shard, progress)
}
