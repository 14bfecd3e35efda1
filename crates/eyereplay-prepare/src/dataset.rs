//! The trajectory dataset on disk:
//!
//! ```text
//! OUT/
//!   reading/reading_0000.csv        frame,x,y[,blink] (canvas px), one per session
//!   conversation/conversation_0000.csv
//!   pool/reading.csv                frame,x,y,source: the class's source pool
//!   labels.csv                      file,label,class,sources
//!   metadata.json                   every parameter and what each source gave
//! ```
//!
//! One folder per class, so Hugging Face's video-folder loader takes the label
//! from the folder once the videos sit beside the CSVs. Every file is written
//! to a temporary name and renamed; `metadata.json` is written last, so its
//! presence marks a complete dataset.

use crate::{Calibration, DatasetConfig, PrepareError, Prepared, SourceReport};
use eyereplay_core::{
    atomic_write_with, push_point_row, push_u64, write_session_csv, write_session_csv_with_blinks,
    CanvasPos, GazeClass,
};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::Path;

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ToolInfo {
    pub name: String,
    pub version: String,
    pub git_revision: Option<String>,
    /// Model files used to extract video sources (empty without video).
    #[serde(default)]
    pub models: Vec<FileDigest>,
}

/// A file and its sha256, for provenance.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct FileDigest {
    pub file: String,
    pub sha256: String,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SessionEntry {
    pub file: String,
    pub class: GazeClass,
    pub label: u8,
    pub index: usize,
    /// First pool frame of the session (`i * stride`).
    pub pool_start: usize,
    pub sources: Vec<u32>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ClassMetadata {
    pub class: GazeClass,
    pub sessions: usize,
    pub pool_frames: usize,
    pub pool_file: String,
    pub stride: usize,
    pub reuse_ratio: f64,
    pub speed_scale: f64,
}

/// Contents of `metadata.json`. Field order is fixed by the struct, so the
/// file is byte-identical for identical inputs.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DatasetMetadata {
    pub tool: ToolInfo,
    pub fps: f64,
    pub session_frames: usize,
    pub canvas: eyereplay_core::Canvas,
    pub seed: u64,
    /// The pooled calibration (normalized iris -> canvas); per-source ones
    /// are in `sources`.
    pub calibration: Option<Calibration>,
    pub calibration_percentile_ranges: Option<[[f64; 2]; 2]>,
    pub global_mean_px: [f64; 2],
    pub classes: Vec<ClassMetadata>,
    pub sources: Vec<SourceReport>,
    pub sessions: Vec<SessionEntry>,
    pub config: DatasetConfig,
}

#[derive(Clone, Debug, Default)]
pub struct WriteSummary {
    pub files: usize,
    pub bytes: u64,
}

pub fn session_file(class: GazeClass, index: usize) -> String {
    format!("{}/{}_{:04}.csv", class.name(), class.name(), index)
}

/// Writes the whole dataset. Sessions are written in parallel; each file is
/// atomic and `metadata.json` comes last.
pub fn write_dataset(
    out: &Path,
    cfg: &DatasetConfig,
    prepared: &Prepared,
    tool: ToolInfo,
) -> Result<(DatasetMetadata, WriteSummary), PrepareError> {
    let mut sessions = Vec::new();
    let mut jobs: Vec<(String, &[CanvasPos], &[bool])> = Vec::new();
    let mut classes = Vec::new();
    for c in &prepared.classes {
        for (i, s) in c.sessions.iter().enumerate() {
            let file = session_file(c.class, i);
            jobs.push((file.clone(), s, &c.session_blinks[i]));
            sessions.push(SessionEntry {
                file,
                class: c.class,
                label: c.class.label(),
                index: i,
                pool_start: i * c.stride,
                sources: c.session_sources[i].clone(),
            });
        }
        classes.push(ClassMetadata {
            class: c.class,
            sessions: c.sessions.len(),
            pool_frames: c.pool.len(),
            pool_file: format!("pool/{}.csv", c.class.name()),
            stride: c.stride,
            reuse_ratio: c.reuse_ratio,
            speed_scale: c.speed_scale,
        });
    }
    // A blink column only when some source marks blinks, so eye-tracker
    // free datasets keep the paper's exact frame,x,y layout.
    let with_blinks = prepared
        .classes
        .iter()
        .any(|c| c.session_blinks.iter().flatten().any(|b| *b));
    jobs.par_iter().try_for_each(|(file, pts, blinks)| {
        if with_blinks {
            write_session_csv_with_blinks(&out.join(file), pts, blinks)
        } else {
            write_session_csv(&out.join(file), pts)
        }
    })?;

    for c in &prepared.classes {
        let path = out.join(format!("pool/{}.csv", c.class.name()));
        atomic_write_with(&path, |w| {
            w.write_all(b"frame,x,y,source\n")?;
            let mut line = Vec::with_capacity(48);
            for (i, (p, s)) in c.pool.iter().zip(&c.pool_source).enumerate() {
                line.clear();
                push_point_row(&mut line, i as u64, *p);
                line.push(b',');
                push_u64(&mut line, *s as u64);
                line.push(b'\n');
                w.write_all(&line)?;
            }
            Ok(())
        })?;
    }

    let ids: Vec<&str> = prepared.sources.iter().map(|s| s.id.as_str()).collect();
    atomic_write_with(&out.join("labels.csv"), |w| {
        w.write_all(b"file,label,class,sources\n")?;
        for s in &sessions {
            let names: Vec<&str> = s.sources.iter().map(|&i| ids[i as usize]).collect();
            writeln!(
                w,
                "{},{},{},{}",
                s.file,
                s.label,
                s.class,
                csv_cell(&names.join(";"))
            )?;
        }
        Ok(())
    })?;

    let meta = DatasetMetadata {
        tool,
        fps: cfg.fps,
        session_frames: cfg.session_frames,
        canvas: cfg.canvas,
        seed: cfg.seed,
        calibration: prepared.calibration,
        calibration_percentile_ranges: prepared.calibration_ranges,
        global_mean_px: [prepared.global_mean.x_px, prepared.global_mean.y_px],
        classes,
        sources: prepared.sources.clone(),
        sessions,
        config: cfg.clone(),
    };
    let json = serde_json::to_vec_pretty(&meta).expect("metadata serializes");
    atomic_write_with(&out.join("metadata.json"), |w| {
        w.write_all(&json)?;
        w.write_all(b"\n")
    })?;

    let mut summary = WriteSummary::default();
    for (file, _, _) in &jobs {
        summary.files += 1;
        summary.bytes += std::fs::metadata(out.join(file))
            .map(|m| m.len())
            .unwrap_or(0);
    }
    summary.files += 2 + prepared.classes.len();
    Ok((meta, summary))
}

/// Quotes a CSV cell when it needs it.
fn csv_cell(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// File name of a path, for ids and labels.
pub(crate) fn display_name(path: &Path) -> String {
    path.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| path.display().to_string())
}
