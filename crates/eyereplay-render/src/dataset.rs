//! Rendering a whole dataset written by `eyereplay prepare`: every session
//! CSV listed in `labels.csv` gets `<stem>.mp4`, `<stem>_truth.csv` and
//! `<stem>_identity.json` beside it. Listing the sessions and telling a
//! whole one; the driver that renders them is eyereplay-backends'.

use crate::rng::mix64;
use crate::{Calibration, GazeMapping, RenderError};
use eyereplay_core::{Canvas, GazeClass};
use eyereplay_dataset::{read_labels, read_metadata, session_paths_of, SessionPaths};
use std::path::Path;

/// What the dataset's metadata says about rendering.
#[derive(Clone, Debug, PartialEq)]
pub struct DatasetInfo {
    pub canvas: Canvas,
    pub fps: f64,
    /// `None` when the dataset has per-source calibrations only (the
    /// default mapping is used).
    pub calibration: Option<Calibration>,
}

/// One session to render.
#[derive(Clone, Debug, PartialEq)]
pub struct SessionJob {
    /// The session's files (`paths.file` is the CSV relative to the dataset
    /// folder, as in labels.csv).
    pub paths: SessionPaths,
    /// Seed of this session's identity.
    pub seed: u64,
    /// Position of this session among the sessions of its class, in
    /// labels.csv order (0 for the first).
    pub class_index: usize,
    /// Its label.
    pub class: GazeClass,
}

impl SessionJob {
    /// Which of `n` shared choices (the full-face mode's photos, the replay
    /// mode's carrier videos) this session takes. Each class's sessions
    /// take them in turn, from a start drawn by the dataset seed that is
    /// the same for every class: within a class the choices' counts differ
    /// by at most one, and two classes of the same size use each choice
    /// equally often, so a classifier trained on the dataset cannot tell
    /// the classes by who is in the video. (Drawn by
    /// each session's seed, the bundled default's 12 sessions used 5 of
    /// its 6 photos, one of them only in reading and two only in
    /// conversation.)
    pub fn balanced_choice(&self, dataset_seed: u64, n: usize) -> usize {
        assert!(n > 0, "balanced_choice among no choices");
        let start = (mix64(dataset_seed ^ 0xBA1A_4CED) % n as u64) as usize;
        (start + self.class_index) % n
    }
}

impl DatasetInfo {
    /// The gaze mapping of this dataset's sessions: its canvas and
    /// calibration, with `template`'s gain and viewing distance.
    pub fn mapping(&self, template: &GazeMapping) -> GazeMapping {
        let mut m = GazeMapping::new(self.canvas);
        if let Some(c) = self.calibration {
            m.calibration = c;
        }
        m.gain = template.gain;
        m.viewing_distance_mm = template.viewing_distance_mm;
        m
    }
}

/// Reads `metadata.json` (canvas, fps, calibration).
pub fn read_dataset_info(dir: &Path) -> Result<DatasetInfo, RenderError> {
    let meta = read_metadata(dir)?.dataset;
    Ok(DatasetInfo {
        canvas: meta.canvas,
        fps: meta.fps,
        calibration: meta.calibration,
    })
}

/// Seed of a session's identity: a hash of the dataset seed and the
/// session's file name, so re-rendering one session gives the same face.
/// Kept below 2^53 so JSON readers that parse numbers as doubles keep it
/// exact.
pub fn session_seed(dataset_seed: u64, file: &str) -> u64 {
    let mut h = mix64(dataset_seed ^ 0xD5E7);
    for b in file.bytes() {
        h = mix64(h ^ b as u64);
    }
    h & ((1 << 53) - 1)
}

/// Lists the sessions of `labels.csv`, in its order.
pub fn list_sessions(dir: &Path, dataset_seed: u64) -> Result<Vec<SessionJob>, RenderError> {
    let labels = read_labels(dir)?;
    let mut per_class = std::collections::BTreeMap::new();
    Ok(session_paths_of(dir, &labels)
        .into_iter()
        .zip(&labels)
        .map(|(paths, label)| {
            let k = per_class.entry(label.class).or_insert(0);
            *k += 1;
            SessionJob {
                seed: session_seed(dataset_seed, &paths.file),
                class_index: *k - 1,
                class: label.class,
                paths,
            }
        })
        .collect())
}
