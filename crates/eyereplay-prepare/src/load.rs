//! Reading every configured source before any processing starts, so a bad
//! file stops the run at once with its name.

use crate::{DatasetConfig, PrepareError, SourceInput};
use eyereplay_core::{sha256_file, GazeClass};
use eyereplay_sources::{read_source, SourceSpec};
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// Checks that every source file exists and is readable; lists all the
/// missing ones in one line.
pub fn check_source_files(cfg: &DatasetConfig) -> Result<(), PrepareError> {
    let mut missing = Vec::new();
    for p in cfg.source_paths() {
        if let Err(e) = std::fs::File::open(&p) {
            missing.push(format!("{} ({e})", p.display()));
        }
    }
    if missing.is_empty() {
        Ok(())
    } else {
        Err(PrepareError::Source {
            id: "sources".into(),
            message: format!("cannot read {}", missing.join("; ")),
        })
    }
}

/// Reads all sources in parallel, in config order. `video_to_csv` turns a
/// video path into the path of its extracted iris CSV (the caller decides
/// how: cached extraction, or an error saying extraction is unavailable).
pub fn load_sources<F>(
    cfg: &DatasetConfig,
    video_to_csv: F,
) -> Result<Vec<SourceInput>, PrepareError>
where
    F: Fn(&Path) -> Result<PathBuf, PrepareError> + Sync,
{
    check_source_files(cfg)?;
    let mut read = cfg.read;
    read.seed = cfg.seed;
    let jobs: Vec<(GazeClass, &SourceSpec)> = cfg
        .classes
        .iter()
        .flat_map(|(c, cc)| cc.sources.iter().map(move |s| (*c, s)))
        .collect();
    let loaded: Vec<Result<Vec<SourceInput>, PrepareError>> = jobs
        .par_iter()
        .map(|(class, written)| {
            let spec = &cfg.resolved_spec(written);
            let sha256 = sha256_file(spec.path())?;
            let (recs, format) = match spec {
                SourceSpec::Video { path } => {
                    let csv = video_to_csv(path)?;
                    (
                        read_source(&SourceSpec::Extract { path: csv }, &read)?,
                        "video",
                    )
                }
                other => (read_source(other, &read)?, other.format_name()),
            };
            Ok(recs
                .into_iter()
                .map(|mut r| {
                    // Ids name the configured file, also for extracted videos.
                    if let SourceSpec::Video { path } = spec {
                        r.id = display_name(path);
                        r.path = path.clone();
                    }
                    SourceInput {
                        class: *class,
                        file: written.path().display().to_string(),
                        format: format.to_string(),
                        sha256: sha256.clone(),
                        recording: r,
                    }
                })
                .collect())
        })
        .collect();
    let mut out = Vec::new();
    for l in loaded {
        out.extend(l?);
    }
    Ok(out)
}

/// File name of a path, for ids and labels.
fn display_name(path: &Path) -> String {
    path.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| path.display().to_string())
}
