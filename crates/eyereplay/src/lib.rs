//! # eyereplay
//!
//! Real human eye movements in, labeled synthetic eye-movement video out:
//! the pipeline of *A Synthetic Eye Movement Dataset for Script Reading
//! Detection*, as a library. The `eyereplay` command is a thin layer of
//! argument parsing and progress bars over these functions.
//!
//! | stage | here | crate that does the work |
//! |---|---|---|
//! | 1 extract iris positions from video | [`extract_videos_cached`] | [`eyereplay_extract`] |
//! | 2-5 calibrate, filter, resample, normalize, slice | [`prepare_dataset`] | [`eyereplay_prepare`] |
//! | 6 render each session to MP4 | [`render_sessions`] | [`eyereplay_render`] |
//! | 7 the dataset on disk | [`finalize`] | [`eyereplay_dataset`] |
//! | 8 evaluate | [`evaluate`] | [`eyereplay_eval`] |
//! | the reading detector: train, detect | [`detector`] | [`eyereplay_detect`] |
//! | all of it, validated first, resumable, shardable | [`plan`] + [`generate`] | |
//!
//! Errors are one [`Error`] enum with a variant per layer; every message is
//! one line naming the file or setting at fault. Long work reports to a
//! [`Progress`] (use [`NoProgress`] to see nothing).
//!
//! ## A dataset from Rust
//!
//! ```
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! # let dir = tempfile::tempdir()?;
//! # let mut gaze = String::from("time,x,y\n");
//! # for i in 0..3000 { // 30 s at 100 Hz: lines read left to right, talk wanders
//! #     let t = i as f64 * 10.0;
//! #     gaze += &format!("{t},{},{}\n", 300.0 + (i % 150) as f64 * 8.0, 400.0 + (i / 150) as f64 * 20.0);
//! # }
//! # std::fs::write(dir.path().join("reader.csv"), &gaze)?;
//! # std::fs::write(dir.path().join("talker.csv"), gaze.replace(",4", ",5"))?;
//! use eyereplay::{prepare_dataset, render_params, render_sessions, NoProgress};
//! use eyereplay::{DatasetConfig, RenderSettings};
//!
//! let mut config = DatasetConfig::parse(r#"
//!     session_frames = 50
//!     [classes.reading]
//!     sessions = 2
//!     sources = [{ format = "csv", path = "reader.csv", time_unit = "ms", screen_px = [1920, 1080] }]
//!     [classes.conversation]
//!     sessions = 2
//!     sources = [{ format = "csv", path = "talker.csv", time_unit = "ms", screen_px = [1920, 1080] }]
//! "#)?;
//! config.base_dir = dir.path().to_path_buf();
//! let out = dir.path().join("dataset");
//! let cache = dir.path().join("cache");
//! prepare_dataset(&config, &out, &cache, &NoProgress)?;           // stages 2-5 + files
//! let settings = RenderSettings { width: Some(320), height: Some(180), ..Default::default() };
//! let params = render_params(&settings, &config)?;
//! let done = render_sessions(&out, &settings, params, None, &NoProgress)?;   // stage 6
//! assert_eq!(done.rendered, 4);
//! assert!(out.join("reading/reading_0001.mp4").is_file());
//! # Ok(())
//! # }
//! ```

mod detection_page;
pub mod detector;
mod error;
mod evaluate;
mod finalize;
mod generate;
mod inputs;
pub mod live;
pub mod profile;

pub use detection_page::detection_page;
pub use error::{Error, Result};
pub use evaluate::{
    evaluate, evaluate_with_progress, EvaluateOptions, EvaluateOutcome, VisualChoice,
};
pub use finalize::{check_labels_against_plan, finalize, finalize_with_progress, missing_sessions};
pub use generate::{
    estimate_bytes_per_frame, generate, plan, plan_config, render_table, GenerateOptions,
    GenerateSummary, Job,
};
pub use inputs::{
    check_models, extract_cached, extract_cached_with, extract_videos_cached,
    extraction_cache_path, extraction_cache_path_for, free_bytes, model_digests, tool_info,
    video_extractions, video_sources, Extracted,
};

pub use eyereplay_backends::{
    check_settings, open_backend, render_dataset, render_params, RenderSummary, ResponseProbe,
    SessionBackend,
};
pub use eyereplay_core::{cache_dir, parse_usize_pair, NoProgress, Progress, Shard, Stage};
pub use eyereplay_dataset::{DatasetMetadata, RenderSettings};
pub use eyereplay_eval::EvalConfig;
pub use eyereplay_prepare::{DatasetConfig, Prepared};

/// The layers, for what the functions above do not cover.
pub use {
    eyereplay_backends as backends, eyereplay_core as core, eyereplay_dataset as dataset,
    eyereplay_detect as detect, eyereplay_eval as eval, eyereplay_extract as extract,
    eyereplay_prepare as prepare_stages, eyereplay_render as render_stage,
    eyereplay_sources as sources,
};

use std::path::Path;

/// Renders the sessions of the dataset in `out` (this shard's only) with
/// the backend `settings` choose; artifacts it measures (carriers) are
/// cached in [`cache_dir`]. See [`eyereplay_backends::render_sessions`].
pub fn render_sessions(
    out: &Path,
    settings: &RenderSettings,
    params: eyereplay_render::RenderParams,
    shard: Option<Shard>,
    progress: &dyn Progress,
) -> Result<RenderSummary> {
    Ok(eyereplay_backends::render_sessions(
        out,
        settings,
        params,
        shard,
        &cache_dir(None),
        progress,
    )?)
}

/// A trajectory dataset written by [`prepare_dataset`].
pub struct PreparedDataset {
    pub prepared: Prepared,
    pub metadata: DatasetMetadata,
    pub files: usize,
    pub bytes: u64,
}

/// Stages 1-5 and the trajectory dataset: extracts the config's videos
/// (cached by content in `cache`), loads every source, calibrates, filters
/// blinks, resamples, normalizes and slices, then writes the session CSVs,
/// pools, labels.csv and metadata.json into `out` (session CSVs an earlier
/// run with more sessions left there are removed).
pub fn prepare_dataset(
    config: &DatasetConfig,
    out: &Path,
    cache: &Path,
    progress: &dyn Progress,
) -> Result<PreparedDataset> {
    eyereplay_dataset::check_output_folder(out)?;
    let prepared = prepare_only(config, cache, progress)?;
    remove_stale_sessions(out, &prepared).map_err(|e| Error::io(out, e))?;
    let tool = tool_info(config)?;
    let (metadata, summary) = eyereplay_dataset::write_dataset(out, config, &prepared, tool)?;
    Ok(PreparedDataset {
        prepared,
        metadata,
        files: summary.files,
        bytes: summary.bytes,
    })
}

/// Stages 1-5 without writing the dataset (for a dry run): what
/// [`prepare_dataset`] would write. Warnings go to `progress`.
pub fn prepare_only(
    config: &DatasetConfig,
    cache: &Path,
    progress: &dyn Progress,
) -> Result<Prepared> {
    let watched = KeepWarnings {
        inner: progress,
        kept: Default::default(),
    };
    let extracted = extract_videos_cached(config, cache, &watched)?;
    let inputs = eyereplay_prepare::load_sources(config, |v, l| extracted.csv_of(v, l))?;
    let mut prepared = eyereplay_prepare::prepare(config, &inputs)?;
    for w in &prepared.warnings {
        progress.warn(&format!("warning: {w}"));
    }
    // The extraction's warnings (a video cut short) were shown as they
    // came; the summary lists them too, for whoever reads it instead.
    let kept = watched.kept.into_inner().unwrap_or_else(|e| e.into_inner());
    prepared.warnings.extend(
        kept.into_iter()
            .map(|w| w.strip_prefix("warning: ").map(str::to_string).unwrap_or(w)),
    );
    Ok(prepared)
}

/// Passes every event on to `inner`, keeping a copy of each warning.
struct KeepWarnings<'a> {
    inner: &'a dyn Progress,
    kept: std::sync::Mutex<Vec<String>>,
}

impl Progress for KeepWarnings<'_> {
    fn begin(&self, stage: Stage, total: u64) {
        self.inner.begin(stage, total);
    }
    fn add_total(&self, units: u64) {
        self.inner.add_total(units);
    }
    fn advance(&self, units: u64) {
        self.inner.advance(units);
    }
    fn status(&self, text: &str) {
        self.inner.status(text);
    }
    fn end(&self, stage: Stage) {
        self.inner.end(stage);
    }
    fn info(&self, line: &str) {
        self.inner.info(line);
    }
    fn warn(&self, line: &str) {
        self.kept
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .push(line.to_string());
        self.inner.warn(line);
    }
}

/// Session CSVs left by an earlier run with more sessions would be mistaken
/// for part of this dataset; remove those beyond the new count.
fn remove_stale_sessions(out: &Path, p: &Prepared) -> std::io::Result<()> {
    for c in &p.classes {
        let Ok(entries) = std::fs::read_dir(out.join(c.class.name())) else {
            continue;
        };
        for e in entries.flatten() {
            let name = e.file_name().to_string_lossy().into_owned();
            if eyereplay_dataset::session_index(c.class, &name)
                .is_some_and(|i| i >= c.sessions.len())
            {
                std::fs::remove_file(e.path())?;
            }
        }
    }
    Ok(())
}
