//! Writing the trajectory dataset that `prepare` computed:
//!
//! ```text
//! OUT/
//!   reading/reading_0000.csv        frame,x,y[,blink][,reading] (canvas px), one per session
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

use crate::labels::{write_labels, LabelRow};
use crate::layout::{pool_file, session_file};
use crate::metadata::{
    write_metadata, ClassMetadata, DatasetMetadata, SessionEntry, ToolInfo, FORMAT_VERSION,
};
use crate::pool::write_pool;
use crate::DatasetError;
use eyereplay_core::{write_session_csv_columns, CanvasPos};
use eyereplay_prepare::{DatasetConfig, Prepared};
use rayon::prelude::*;
use std::path::Path;

/// One session CSV to write: file, points, blink flags, reading flags.
type SessionJob<'a> = (String, &'a [CanvasPos], &'a [bool], &'a [bool]);

#[derive(Clone, Debug, Default)]
pub struct WriteSummary {
    pub files: usize,
    pub bytes: u64,
}

/// Writes the whole dataset. Sessions are written in parallel; each file is
/// atomic and `metadata.json` comes last.
pub fn write_dataset(
    out: &Path,
    cfg: &DatasetConfig,
    prepared: &Prepared,
    tool: ToolInfo,
) -> Result<(DatasetMetadata, WriteSummary), DatasetError> {
    let mut sessions = Vec::new();
    let mut jobs: Vec<SessionJob> = Vec::new();
    let mut classes = Vec::new();
    for c in &prepared.classes {
        for (i, s) in c.sessions.iter().enumerate() {
            let file = session_file(c.class, i);
            jobs.push((file.clone(), s, &c.session_blinks[i], &c.session_reading[i]));
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
            pool_file: pool_file(c.class),
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
    // A per-frame reading column when behaviour models made sources: an
    // interview switches between reading and talk within a session.
    let with_reading = cfg.has_generators();
    jobs.par_iter()
        .try_for_each(|(file, pts, blinks, reading)| {
            write_session_csv_columns(
                &out.join(file),
                pts,
                with_blinks.then_some(*blinks),
                with_reading.then_some(*reading),
            )
        })?;

    for c in &prepared.classes {
        write_pool(
            &out.join(pool_file(c.class)),
            &c.pool,
            &c.pool_source,
            &c.pool_time_s,
        )?;
    }

    let ids: Vec<&str> = prepared.sources.iter().map(|s| s.id.as_str()).collect();
    let labels: Vec<LabelRow> = sessions
        .iter()
        .map(|s| LabelRow {
            file: s.file.clone(),
            class: s.class,
            sources: s
                .sources
                .iter()
                .map(|&i| ids[i as usize].to_string())
                .collect(),
        })
        .collect();
    write_labels(out, &labels)?;

    let meta = DatasetMetadata {
        format_version: FORMAT_VERSION,
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
    write_metadata(out, &meta)?;

    let mut summary = WriteSummary::default();
    for (file, _, _, _) in &jobs {
        summary.files += 1;
        summary.bytes += std::fs::metadata(out.join(file))
            .map(|m| m.len())
            .unwrap_or(0);
    }
    summary.files += 2 + prepared.classes.len();
    Ok((meta, summary))
}
