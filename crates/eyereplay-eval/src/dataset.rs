//! A dataset folder loaded for evaluation: every session and each class's
//! source pool, read through the dataset format crate
//! ([`eyereplay_dataset`]), which owns every file name and column.

use crate::EvalError;
use eyereplay_core::{read_session_csv, Canvas, GazeClass};
use eyereplay_dataset::{
    pool_file, read_blink_column, read_labels, read_metadata, read_pool, DatasetMetadata,
};
use std::path::{Path, PathBuf};

pub use eyereplay_dataset::Segment;

/// One generated session.
#[derive(Clone, Debug, PartialEq)]
pub struct Session {
    /// Path relative to the dataset folder, as in labels.csv.
    pub file: String,
    pub points: Vec<[f64; 2]>,
    /// The optional `blink` column (1 where the source blinked).
    pub blinks: Option<Vec<bool>>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct ClassData {
    pub class: GazeClass,
    pub sessions: Vec<Session>,
    /// The concatenated source pool, split where the source changes.
    pub pool: Vec<Segment>,
    /// How the class's sources were recorded (`metadata.json`
    /// `sources[].kind`: video, eye_tracker, fixation_report) and how many
    /// sources of each kind; empty when the metadata lists no sources.
    pub source_kinds: std::collections::BTreeMap<String, usize>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Dataset {
    pub dir: PathBuf,
    pub fps: f64,
    pub canvas: Canvas,
    pub session_frames: usize,
    /// In [`GazeClass::ALL`] order.
    pub classes: Vec<ClassData>,
    /// The whole metadata.json, typed.
    pub metadata: DatasetMetadata,
}

/// Loads and checks a whole dataset folder.
pub fn load_dataset(dir: &Path) -> Result<Dataset, EvalError> {
    if !dir.is_dir() {
        return Err(EvalError::dataset(dir, "not a folder"));
    }
    let labels = read_labels(dir)?;
    let meta = read_metadata(dir)?.dataset;
    let session_frames = meta.session_frames;
    let mut classes = Vec::new();
    for class in GazeClass::ALL {
        let files: Vec<&String> = labels
            .iter()
            .filter(|l| l.class == class)
            .map(|l| &l.file)
            .collect();
        if files.is_empty() {
            return Err(EvalError::dataset(
                dir.join(eyereplay_dataset::layout::LABELS_FILE),
                // As `generate` says it up front: each class is measured
                // against its own pool, but the report and its detector
                // checks are made for both.
                format!(
                    "class '{class}' has no sessions, and the evaluation needs both classes \
                     (a dataset of one class can be rendered, not evaluated)"
                ),
            ));
        }
        let mut sessions = Vec::with_capacity(files.len());
        for f in files {
            let path = dir.join(f);
            let pts = read_session_csv(&path)?;
            if pts.len() != session_frames {
                return Err(EvalError::dataset(
                    &path,
                    format!(
                        "{} frames, but metadata.json says session_frames = {session_frames}",
                        pts.len()
                    ),
                ));
            }
            sessions.push(Session {
                file: f.clone(),
                points: pts.iter().map(|p| [p.x_px, p.y_px]).collect(),
                blinks: read_blink_column(&path)?,
            });
        }
        let pool = read_pool(&dir.join(pool_file(class)))?;
        classes.push(ClassData {
            class,
            sessions,
            pool,
            source_kinds: meta.source_kinds(class),
        });
    }
    Ok(Dataset {
        dir: dir.to_path_buf(),
        fps: meta.fps,
        canvas: meta.canvas,
        session_frames,
        classes,
        metadata: meta,
    })
}
