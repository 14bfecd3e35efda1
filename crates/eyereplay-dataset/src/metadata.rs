//! `metadata.json`: every parameter of a dataset and what each source gave.
//!
//! Written twice: by `prepare` (the trajectory dataset, [`DatasetMetadata`])
//! and again, with a `render` section, when every session is rendered
//! ([`Metadata`]). Field order is fixed by the structs, so the file is
//! byte-identical for identical inputs. `format_version` says which layout
//! of the dataset folder the file describes; a reader refuses any other.

use crate::error::read_text;
use crate::identity::SessionIdentity;
use crate::layout::METADATA_FILE;
use crate::DatasetError;
use eyereplay_core::{Calibration, Canvas, GazeClass};
use eyereplay_prepare::{DatasetConfig, SourceReport};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Version of the dataset layout this build writes and reads. Version 1 is
/// the first layout (datasets written before the field existed have the
/// same layout and read as version 1). Bump it when a file's meaning or
/// columns change, and say what changed in docs/DATASET.md.
pub const FORMAT_VERSION: u32 = 1;

fn format_version_default() -> u32 {
    FORMAT_VERSION
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ToolInfo {
    pub name: String,
    pub version: String,
    pub git_revision: Option<String>,
    /// Model files used to extract video sources (empty without video).
    #[serde(default)]
    pub models: Vec<FileDigest>,
}

impl ToolInfo {
    /// This eyereplay, with the model files that extracted its videos.
    pub fn this_build(git_revision: Option<String>, models: Vec<FileDigest>) -> Self {
        ToolInfo {
            name: "eyereplay".into(),
            version: eyereplay_core::TOOL_VERSION.into(),
            git_revision,
            models,
        }
    }
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

/// What `prepare` writes to `metadata.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DatasetMetadata {
    /// [`FORMAT_VERSION`] of the writer.
    #[serde(default = "format_version_default")]
    pub format_version: u32,
    pub tool: ToolInfo,
    pub fps: f64,
    pub session_frames: usize,
    pub canvas: Canvas,
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

/// The whole `metadata.json`: the prepared dataset, plus, once every
/// session is rendered, each session's identity and geometry.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Metadata {
    #[serde(flatten)]
    pub dataset: DatasetMetadata,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub render: Option<RenderMetadata>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RenderMetadata {
    /// Per session: seed, identity (iris, skin, eye shape, lighting,
    /// camera), gaze mapping, video size and eye geometry, as written beside
    /// each video; keys sorted, as metadata.json has always had them here.
    #[serde(serialize_with = "keys_sorted")]
    pub sessions: Vec<SessionIdentity>,
}

/// Serializes through serde's value tree, whose objects are sorted maps.
fn keys_sorted<S: serde::Serializer>(v: &[SessionIdentity], s: S) -> Result<S::Ok, S::Error> {
    let tree = serde_json::to_value(v).map_err(serde::ser::Error::custom)?;
    sort_value(tree).serialize(s)
}

/// Rebuilds every object with its keys in sorted order (serde_json keeps
/// insertion order when another crate enables `preserve_order`).
fn sort_value(v: serde_json::Value) -> SortedValue {
    match v {
        serde_json::Value::Object(m) => {
            SortedValue::Object(m.into_iter().map(|(k, v)| (k, sort_value(v))).collect())
        }
        serde_json::Value::Array(a) => SortedValue::Array(a.into_iter().map(sort_value).collect()),
        other => SortedValue::Leaf(other),
    }
}

#[derive(Serialize)]
#[serde(untagged)]
enum SortedValue {
    Object(std::collections::BTreeMap<String, SortedValue>),
    Array(Vec<SortedValue>),
    Leaf(serde_json::Value),
}

impl DatasetMetadata {
    /// Metadata for a dataset assembled without `prepare` (imported session
    /// CSVs, tests): the given rate, size and pooled calibration, one class
    /// entry per `(class, sessions, pool_frames)` with sessions numbered as
    /// [`session_file`](crate::session_file) names them, and no sources.
    pub fn assembled(
        fps: f64,
        session_frames: usize,
        canvas: Canvas,
        calibration: Option<Calibration>,
        classes: &[(GazeClass, usize, usize)],
    ) -> Self {
        let mut config = DatasetConfig::parse("classes = {}").expect("an empty config parses");
        config.fps = fps;
        config.session_frames = session_frames;
        config.canvas = canvas;
        let mut sessions = Vec::new();
        let mut class_meta = Vec::new();
        for &(class, n, pool_frames) in classes {
            let stride = pool_frames / n.max(1);
            for i in 0..n {
                sessions.push(SessionEntry {
                    file: crate::session_file(class, i),
                    class,
                    label: class.label(),
                    index: i,
                    pool_start: i * stride,
                    sources: Vec::new(),
                });
            }
            class_meta.push(ClassMetadata {
                class,
                sessions: n,
                pool_frames,
                pool_file: crate::pool_file(class),
                stride,
                reuse_ratio: (n * session_frames) as f64 / pool_frames.max(1) as f64,
                speed_scale: 1.0,
            });
        }
        DatasetMetadata {
            format_version: FORMAT_VERSION,
            tool: ToolInfo::this_build(None, Vec::new()),
            fps,
            session_frames,
            canvas,
            seed: 0,
            calibration,
            calibration_percentile_ranges: None,
            global_mean_px: [canvas.width_px as f64 / 2.0, canvas.height_px as f64 / 2.0],
            classes: class_meta,
            sources: Vec::new(),
            sessions,
            config,
        }
    }

    /// The class's entry, if the dataset has the class.
    pub fn class(&self, class: GazeClass) -> Option<&ClassMetadata> {
        self.classes.iter().find(|c| c.class == class)
    }

    /// The session entry of `file` (relative, as in labels.csv).
    pub fn session(&self, file: &str) -> Option<&SessionEntry> {
        self.sessions.iter().find(|s| s.file == file)
    }

    /// Counts of the class's sources by recording kind (`video`,
    /// `eye_tracker`, `fixation_report`).
    pub fn source_kinds(&self, class: GazeClass) -> std::collections::BTreeMap<String, usize> {
        let mut out = std::collections::BTreeMap::new();
        for s in self.sources.iter().filter(|s| s.class == class) {
            // The kind's name as metadata.json spells it (snake_case).
            let kind = serde_json::to_value(s.kind)
                .ok()
                .and_then(|v| v.as_str().map(str::to_string))
                .unwrap_or_default();
            *out.entry(kind).or_insert(0) += 1;
        }
        out
    }
}

/// Reads `<dir>/metadata.json`, checking its format version first, so that
/// a dataset of another layout gets one clear error rather than a missing
/// key.
pub fn read_metadata(dir: &Path) -> Result<Metadata, DatasetError> {
    let path = dir.join(METADATA_FILE);
    let text = read_text(&path)?;
    parse_metadata(&text, &path)
}

/// [`read_metadata`] on text already read; `path` names it in errors.
pub fn parse_metadata(text: &str, path: &Path) -> Result<Metadata, DatasetError> {
    #[derive(Deserialize)]
    struct Header {
        #[serde(default = "format_version_default")]
        format_version: u32,
        #[serde(default)]
        tool: Option<serde_json::Value>,
    }
    let header: Header = serde_json::from_str(text)
        .map_err(|e| DatasetError::invalid(path, format!("not eyereplay metadata: {e}")))?;
    if header.format_version != FORMAT_VERSION {
        let written_by = header
            .tool
            .as_ref()
            .and_then(|t| t.get("version"))
            .and_then(|v| v.as_str())
            .map(|v| format!("eyereplay {v}"))
            .unwrap_or_else(|| "unknown".into());
        return Err(DatasetError::Version {
            path: path.to_path_buf(),
            found: header.format_version,
            expected: FORMAT_VERSION,
            tool: eyereplay_core::TOOL_VERSION,
            written_by,
        });
    }
    let meta: Metadata = serde_json::from_str(text)
        .map_err(|e| DatasetError::invalid(path, format!("not eyereplay metadata: {e}")))?;
    meta.check(path)?;
    Ok(meta)
}

impl Metadata {
    /// Consistency a reader relies on: positive rates and sizes, and
    /// calibrations that can be inverted.
    fn check(&self, path: &Path) -> Result<(), DatasetError> {
        let d = &self.dataset;
        let bad = |m: String| Err(DatasetError::invalid(path, m));
        if !(d.fps.is_finite() && d.fps > 0.0) {
            return bad(format!("fps must be a positive number, found {}", d.fps));
        }
        if d.session_frames == 0 {
            return bad("session_frames must be at least 1".into());
        }
        if d.canvas.width_px == 0 || d.canvas.height_px == 0 {
            return bad("canvas width_px and height_px must be positive".into());
        }
        let cals = d
            .calibration
            .iter()
            .map(|c| ("calibration".to_string(), c))
            .chain(
                d.sources
                    .iter()
                    .map(|s| (format!("sources[{}].calibration", s.index), &s.calibration)),
            );
        for (name, c) in cals {
            let finite = [c.s_x, c.s_y, c.mu_x, c.mu_y].iter().all(|v| v.is_finite());
            if !finite || c.s_x == 0.0 || c.s_y == 0.0 {
                return bad(format!(
                    "{name}: scales must be non-zero and all values finite"
                ));
            }
        }
        Ok(())
    }
}

/// Serializes metadata the one way it is written: pretty JSON with a final
/// newline.
pub fn metadata_bytes<T: Serialize>(meta: &T) -> Vec<u8> {
    let mut json = serde_json::to_vec_pretty(meta)
        .expect("metadata serializes: no map keys that are not strings");
    json.push(b'\n');
    json
}

/// Writes `metadata.json` atomically.
pub fn write_metadata<T: Serialize>(dir: &Path, meta: &T) -> Result<(), DatasetError> {
    let json = metadata_bytes(meta);
    eyereplay_core::atomic_write(&dir.join(METADATA_FILE), &json)?;
    Ok(())
}
