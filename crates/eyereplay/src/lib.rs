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

pub mod detector;
pub mod detector_eval;
mod detector_report;
mod error;
mod evaluate;
pub mod face;
mod finalize;
mod generate;
mod inputs;
mod progress;
mod render;
pub mod replay;
pub mod replay_eval;
mod response;
mod shard;
pub mod source_head;

pub use error::{Error, Result};
pub use evaluate::{evaluate, EvaluateOptions, EvaluateOutcome, VisualChoice};
pub use finalize::{finalize, missing_sessions};
pub use generate::{
    estimate_bytes_per_frame, generate, plan, plan_config, GenerateOptions, GenerateSummary, Job,
};
pub use inputs::{
    cache_dir, check_ffmpeg, check_models, extract_videos_cached, fetch_models, free_bytes,
    model_digests, tool_info, video_sources, Extracted,
};
pub use progress::{NoProgress, Progress, Stage};
pub use render::{browser_settings, render_params, render_sessions, RenderSummary};
pub use response::{match_extractor_probe, measure_response, response_probe};
pub use shard::Shard;

pub use eyereplay_dataset::{DatasetMetadata, RenderSettings};
pub use eyereplay_eval::EvalConfig;
pub use eyereplay_prepare::{DatasetConfig, Prepared};

/// The layers, for what the functions above do not cover.
pub use {
    eyereplay_core as core, eyereplay_dataset as dataset, eyereplay_detect as detect,
    eyereplay_eval as eval, eyereplay_extract as extract, eyereplay_prepare as prepare_stages,
    eyereplay_render as render_stage, eyereplay_sources as sources,
};

use std::path::Path;

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
    let extracted = extract_videos_cached(config, cache, progress)?;
    let inputs = eyereplay_prepare::load_sources(config, |v| extracted.csv_of(v))?;
    let prepared = eyereplay_prepare::prepare(config, &inputs)?;
    for w in &prepared.warnings {
        progress.warn(&format!("warning: {w}"));
    }
    Ok(prepared)
}

/// Session CSVs left by an earlier run with more sessions would be mistaken
/// for part of this dataset; remove those beyond the new count.
fn remove_stale_sessions(out: &Path, p: &Prepared) -> std::io::Result<()> {
    for c in &p.classes {
        let dir = out.join(c.class.name());
        let Ok(entries) = std::fs::read_dir(&dir) else {
            continue;
        };
        let prefix = format!("{}_", c.class.name());
        for e in entries.flatten() {
            let name = e.file_name().to_string_lossy().into_owned();
            let Some(num) = name
                .strip_prefix(&prefix)
                .and_then(|r| r.strip_suffix(".csv"))
            else {
                continue;
            };
            if num.len() == 4 && num.parse::<usize>().is_ok_and(|i| i >= c.sessions.len()) {
                std::fs::remove_file(e.path())?;
            }
        }
    }
    Ok(())
}

/// Two numbers joined by one of `seps`, as in `--shard 0/4` or `--size
/// 1280x720`; errors name the flag, the value and the expected form.
pub fn parse_usize_pair(
    flag: &str,
    s: &str,
    seps: &[char],
    form: &str,
    names: [&str; 2],
) -> Result<(usize, usize)> {
    let (a, b) = s
        .split_once(seps)
        .ok_or_else(|| Error::Setting(format!("{flag} '{s}': expected {form}")))?;
    let num = |v: &str, name: &str| -> Result<usize> {
        v.trim()
            .parse()
            .map_err(|_| Error::Setting(format!("{flag} '{s}': {name} is not a number")))
    };
    Ok((num(a, names[0])?, num(b, names[1])?))
}
