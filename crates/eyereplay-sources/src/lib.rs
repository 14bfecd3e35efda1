//! Readers that turn gaze recordings into trajectories of normalized iris
//! positions ([`NormPos`]), the common input of the trajectory pipeline.
//!
//! | format | what | native unit |
//! |---|---|---|
//! | `extract` | `eyereplay extract`'s per-frame CSV | normalized iris |
//! | `csv` | generic eye-tracker samples, CSV or TSV | screen px |
//! | `eyelink` | EyeLink ASCII `.asc` samples | screen px |
//! | `bids` | BIDS eye tracking `*_physio.tsv[.gz]` + JSON sidecar | screen px |
//! | `fixations` | one row per fixation (start, end, x, y) | screen px |
//!
//! Screen-pixel sources are converted to normalized iris positions by the
//! documented eye model in [`screen`], so webcam and eye-tracker sources share
//! one calibration and keep their physical amplitudes relative to each other.
//! Recordings are split into segments wherever the timestamps jump by more
//! than `max_gap_s` (recording blocks, long tracking loss): the pipeline never
//! interpolates across such a gap.

mod bids;
mod error;
mod extract_csv;
mod eyelink;
mod fixations;
mod samples_csv;
pub mod screen;
mod series;

use eyereplay_core::{LandmarkModel, NormPos, Trajectory};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

pub use error::SourceError;
pub use fixations::SaccadeModel;
pub use screen::{EyeGains, ViewingGeometry};
pub use series::NO_GAZE_SEGMENT;

/// Unit of a time column. Named explicitly because eye-tracking tools switch
/// silently between milliseconds, seconds and sample counts.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum TimeUnit {
    S,
    #[default]
    Ms,
    Us,
}

impl TimeUnit {
    pub fn to_seconds(self, v: f64) -> f64 {
        match self {
            TimeUnit::S => v,
            TimeUnit::Ms => v * 1e-3,
            TimeUnit::Us => v * 1e-6,
        }
    }
}

/// Which eye a binocular eye-tracker source contributes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum EyeChoice {
    Left,
    Right,
    /// Mean of both eyes where both are valid, else whichever is valid.
    #[default]
    Mean,
}

/// Screen of an EyeLink or BIDS source; read from the file when absent.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct ScreenOptions {
    /// Screen size `[width, height]` in px.
    pub screen_px: Option<[f64; 2]>,
    pub geometry: ViewingGeometry,
}

/// One configured source: a file and how to read it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "format", rename_all = "lowercase", deny_unknown_fields)]
pub enum SourceSpec {
    /// `eyereplay extract` output.
    Extract { path: PathBuf },
    /// A video file; extracted by `eyereplay extract` before preparation,
    /// with the landmark networks `landmarks` names (by default the
    /// cascade, with which the smoothing, the bundled default and the
    /// detector were measured).
    Video {
        path: PathBuf,
        // Left out when the default, so that a config without the key
        // writes the metadata it wrote before the key existed.
        #[serde(default, skip_serializing_if = "is_cascade")]
        landmarks: LandmarkModel,
    },
    /// Generic samples table (CSV, or TSV when the name ends in `.tsv`).
    Csv {
        path: PathBuf,
        /// Column names; defaults try `time`/`timestamp`/`t`, `x`/`x_px`/
        /// `pixel_x`/`gaze_x`, `y`/... in that order.
        #[serde(default)]
        time_column: Option<String>,
        #[serde(default)]
        x_column: Option<String>,
        #[serde(default)]
        y_column: Option<String>,
        #[serde(default)]
        time_unit: TimeUnit,
        screen_px: [f64; 2],
        #[serde(default)]
        geometry: ViewingGeometry,
    },
    /// EyeLink ASCII samples (`edf2asc` output).
    Eyelink {
        path: PathBuf,
        #[serde(default)]
        eye: EyeChoice,
        #[serde(default)]
        screen_px: Option<[f64; 2]>,
        #[serde(default)]
        geometry: ViewingGeometry,
    },
    /// BIDS eye tracking: `*_physio.tsv[.gz]` with its `*_physio.json`.
    Bids {
        path: PathBuf,
        #[serde(default)]
        screen_px: Option<[f64; 2]>,
        #[serde(default)]
        geometry: ViewingGeometry,
    },
    /// Fixation report, one row per fixation, turned into samples.
    Fixations {
        path: PathBuf,
        #[serde(default = "fixations::default_start")]
        start_column: String,
        #[serde(default = "fixations::default_end")]
        end_column: String,
        #[serde(default = "fixations::default_x")]
        x_column: String,
        #[serde(default = "fixations::default_y")]
        y_column: String,
        /// Rows with equal values in these columns form one recording
        /// (e.g. participant and trial).
        #[serde(default)]
        group_columns: Vec<String>,
        /// Saccade amplitude column in degrees, used to estimate px/deg
        /// when `px_per_deg` is not given.
        #[serde(default)]
        amplitude_column: Option<String>,
        #[serde(default)]
        time_unit: TimeUnit,
        screen_px: [f64; 2],
        #[serde(default)]
        geometry: ViewingGeometry,
        #[serde(default)]
        saccade: SaccadeModel,
    },
}

fn is_cascade(m: &LandmarkModel) -> bool {
    *m == LandmarkModel::Cascade
}

/// The `path` field of any variant, by reference or by mutable reference.
macro_rules! spec_path {
    ($spec:expr) => {
        match $spec {
            SourceSpec::Extract { path }
            | SourceSpec::Video { path, .. }
            | SourceSpec::Csv { path, .. }
            | SourceSpec::Eyelink { path, .. }
            | SourceSpec::Bids { path, .. }
            | SourceSpec::Fixations { path, .. } => path,
        }
    };
}

impl SourceSpec {
    pub fn path(&self) -> &Path {
        spec_path!(self)
    }

    pub fn path_mut(&mut self) -> &mut PathBuf {
        spec_path!(self)
    }

    pub fn format_name(&self) -> &'static str {
        match self {
            SourceSpec::Extract { .. } => "extract",
            SourceSpec::Video { .. } => "video",
            SourceSpec::Csv { .. } => "csv",
            SourceSpec::Eyelink { .. } => "eyelink",
            SourceSpec::Bids { .. } => "bids",
            SourceSpec::Fixations { .. } => "fixations",
        }
    }
}

/// How the samples of a recording came about; decides resampling.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RecordingKind {
    /// Landmarks from video frames (15-30 fps, jittery): the paper's case.
    Video,
    /// A dedicated eye tracker (typically 250-2000 Hz).
    EyeTracker,
    /// Samples synthesized from a fixation report.
    FixationReport,
    /// Samples generated by a behaviour model (`generators`), no recording.
    Model,
}

/// A loaded recording: one or more gap-free segments of normalized iris
/// positions.
#[derive(Clone, Debug)]
pub struct Recording {
    /// Stable identifier: the file name, plus the group key for fixation
    /// reports (`fixations.csv#l37_1129/44`).
    pub id: String,
    pub path: PathBuf,
    pub kind: RecordingKind,
    /// Median sampling rate of the samples as stored (Hz).
    pub rate_hz: f64,
    pub segments: Vec<Trajectory<NormPos>>,
    /// Pixels per degree used to convert screen positions, if any.
    pub px_per_deg: Option<f64>,
}

impl Recording {
    pub fn sample_count(&self) -> usize {
        self.segments.iter().map(|s| s.len()).sum()
    }
}

/// Settings every reader shares.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ReadOptions {
    /// Split a recording where consecutive timestamps are further apart.
    pub max_gap_s: f64,
    /// Eye model for converting screen positions to iris positions.
    pub eye_gains: EyeGains,
    /// Seed for synthesized detail (fixational drift); the dataset's seed.
    #[serde(skip)]
    pub seed: u64,
}

impl Default for ReadOptions {
    fn default() -> Self {
        ReadOptions {
            max_gap_s: 1.0,
            eye_gains: EyeGains::default(),
            seed: 0,
        }
    }
}

/// Reads one configured source. Fixation reports with `group_columns` yield
/// one recording per group; every other format yields one.
pub fn read_source(spec: &SourceSpec, opts: &ReadOptions) -> Result<Vec<Recording>, SourceError> {
    match spec {
        SourceSpec::Extract { path } => Ok(vec![extract_csv::read(path, opts)?]),
        SourceSpec::Video { path, .. } => Err(SourceError::file(
            path,
            "video sources are extracted first; call the extractor, then read its CSV",
        )),
        SourceSpec::Csv {
            path,
            time_column,
            x_column,
            y_column,
            time_unit,
            screen_px,
            geometry,
        } => Ok(vec![samples_csv::read(
            path,
            samples_csv::Columns {
                time: time_column.as_deref(),
                x: x_column.as_deref(),
                y: y_column.as_deref(),
            },
            *time_unit,
            *screen_px,
            geometry,
            opts,
        )?]),
        SourceSpec::Eyelink {
            path,
            eye,
            screen_px,
            geometry,
        } => {
            let screen = ScreenOptions {
                screen_px: *screen_px,
                geometry: *geometry,
            };
            Ok(vec![eyelink::read(path, *eye, &screen, opts)?])
        }
        SourceSpec::Bids {
            path,
            screen_px,
            geometry,
        } => {
            let screen = ScreenOptions {
                screen_px: *screen_px,
                geometry: *geometry,
            };
            Ok(vec![bids::read(path, &screen, opts)?])
        }
        SourceSpec::Fixations { .. } => fixations::read(spec, opts),
    }
}

/// File name for ids and messages.
pub(crate) fn file_name(path: &Path) -> String {
    path.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| path.display().to_string())
}
