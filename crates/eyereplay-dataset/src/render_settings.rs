//! The `[render]` table of a dataset config, typed once at load time.
//!
//! The config keeps the table as the user wrote it (so `metadata.json`
//! records exactly that); [`RenderSettings::from_config`] turns it into this
//! struct with defaults filled in, and rejects unknown keys and wrong types
//! with the config file's name and the key.

use crate::DatasetError;
use eyereplay_prepare::DatasetConfig;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The `[render]` table of a dataset config: the keys every backend reads,
/// and the chosen backend with its own keys. A key that does not apply to
/// the chosen backend is an error naming it, so a setting is never
/// silently ignored.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderSettings {
    /// Video width in px; default: the canvas width.
    pub width: Option<usize>,
    /// Video height in px; default: the canvas height.
    pub height: Option<usize>,
    /// Amplification of the iris excursion (1 = the source's amplitude).
    pub gain: f64,
    /// Distance from the eyes to the screen, for vergence (mm).
    pub viewing_distance_mm: f64,
    /// Blink at a natural rate (besides the sources' own blinks).
    pub natural_blinks: bool,
    /// x264 preset.
    pub preset: String,
    /// x264 constant rate factor.
    pub crf: u32,
    /// Sessions rendered at once; 0 = one per core (our renderer) or one
    /// browser per two cores (the browser backend).
    pub jobs: usize,
    /// The simulator and its own settings.
    pub backend: BackendSettings,
}

/// `render.match_extractor` and the extractor it matches: the eyes and
/// face backends draw each identity's eye where the extractor's iris model
/// reads the trajectory's position.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ExtractorMatchSettings {
    /// Measure the response per session from probe frames (needs the
    /// models) and draw through its inverse.
    pub match_extractor: bool,
    /// Crops per eye the extractor reads, 1-9, in the probe and in the
    /// evaluation's read-back (recorded as `extractor_iris_views`).
    pub extractor_iris_views: usize,
}

/// The chosen simulator (`render.backend`) and the keys that are its own.
#[derive(Clone, Debug, PartialEq)]
pub enum BackendSettings {
    /// eyereplay's own ray-traced eyes (the default).
    Eyes { extractor: ExtractorMatchSettings },
    /// A web page driven frame by frame in a headless Chromium.
    Browser {
        /// `[render.browser]`, typed by the browser backend.
        browser: Option<toml::Table>,
        /// Where the page draws its eyes (per eye `[inner_x, inner_y,
        /// outer_x, outer_y]` in video px, image-left eye first), for the
        /// read-back.
        eye_corners_px: Option<[[f64; 4]; 2]>,
    },
    /// A whole face from a real photo in a webcam frame.
    Face(FaceBackendSettings),
    /// A real video of a person, their irises redrawn.
    Replay {
        /// Carrier videos; empty = the bundled ones.
        carriers: Vec<std::path::PathBuf>,
    },
}

/// The most frames `render.match_readback_every` may step over: past a few
/// the extractor's tracker lags a turning head (3 already did,
/// docs/PERFORMANCE.md); 10 bounds a typo, not a tested setting.
pub const MAX_MATCH_READBACK_EVERY: usize = 10;

/// The most sessions `render.jobs` (and `render --jobs`) may draw at once:
/// each is a thread with its own frame buffers and encoder process, so
/// past the cores they only share the CPU (a typo of 100,000 built
/// threads for minutes).
pub const MAX_JOBS: usize = 256;

/// The full-face backend's keys.
#[derive(Clone, Debug, PartialEq)]
pub struct FaceBackendSettings {
    pub extractor: ExtractorMatchSettings,
    /// After the probe, draw once, read back, refit and draw again.
    pub match_readback: bool,
    /// The read-back match's first pass draws every this many frames.
    pub match_readback_every: usize,
    /// Frontal photos whose faces become the identities; empty = bundled.
    pub identities: Vec<std::path::PathBuf>,
    /// The face's height over the frame height, drawn from this range.
    pub face_height_frac: [f64; 2],
    /// Scale of the head's drift and sway (0 = none, 1 = default RMS).
    pub head_sway: f64,
    /// What moves the head.
    pub head_motion: HeadMotion,
    /// `[render.webcam]`, typed by the face backend.
    pub webcam: Option<toml::Table>,
}

impl BackendSettings {
    /// The backend's name, as `render.backend` spells it.
    pub fn kind(&self) -> RenderBackend {
        match self {
            BackendSettings::Eyes { .. } => RenderBackend::Eyes,
            BackendSettings::Browser { .. } => RenderBackend::Browser,
            BackendSettings::Face(_) => RenderBackend::Face,
            BackendSettings::Replay { .. } => RenderBackend::Replay,
        }
    }

    /// The extractor match, for the backends that have one.
    pub fn extractor(&self) -> Option<ExtractorMatchSettings> {
        match self {
            BackendSettings::Eyes { extractor } => Some(*extractor),
            BackendSettings::Face(f) => Some(f.extractor),
            _ => None,
        }
    }
}

impl RenderBackend {
    /// As `render.backend` spells it.
    pub fn name(self) -> &'static str {
        match self {
            RenderBackend::Eyes => "eyes",
            RenderBackend::Browser => "browser",
            RenderBackend::Face => "face",
            RenderBackend::Replay => "replay",
        }
    }

    /// The `[render]` keys that apply to this backend besides `backend`.
    pub fn keys(self) -> &'static [&'static str] {
        match self {
            RenderBackend::Eyes => &[
                "width",
                "height",
                "gain",
                "viewing_distance_mm",
                "natural_blinks",
                "preset",
                "crf",
                "jobs",
                "match_extractor",
                "extractor_iris_views",
            ],
            RenderBackend::Browser => &[
                "width",
                "height",
                "gain",
                "viewing_distance_mm",
                "preset",
                "crf",
                "jobs",
                "browser",
                "browser_eye_corners_px",
            ],
            RenderBackend::Face => &[
                "width",
                "height",
                "gain",
                "viewing_distance_mm",
                "natural_blinks",
                "jobs",
                "match_extractor",
                "extractor_iris_views",
                "match_readback",
                "match_readback_every",
                "identities",
                "face_height_frac",
                "head_sway",
                "head_motion",
                "webcam",
            ],
            RenderBackend::Replay => &["gain", "viewing_distance_mm", "preset", "crf", "carriers"],
        }
    }
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderTable::default().into_settings()
    }
}

impl Default for FaceBackendSettings {
    /// The face backend's keys when `[render]` has only `backend = "face"`.
    fn default() -> Self {
        let raw = RenderTable {
            backend: RenderBackend::Face,
            ..RenderTable::default()
        };
        match raw.into_settings().backend {
            BackendSettings::Face(f) => f,
            _ => unreachable!("a face table gives face settings"),
        }
    }
}

impl RenderTable {
    fn into_settings(self) -> RenderSettings {
        let extractor = ExtractorMatchSettings {
            match_extractor: self.match_extractor,
            extractor_iris_views: self.extractor_iris_views,
        };
        let backend = match self.backend {
            RenderBackend::Eyes => BackendSettings::Eyes { extractor },
            RenderBackend::Browser => BackendSettings::Browser {
                browser: self.browser,
                eye_corners_px: self.browser_eye_corners_px,
            },
            RenderBackend::Face => BackendSettings::Face(FaceBackendSettings {
                extractor,
                match_readback: self.match_readback,
                match_readback_every: self.match_readback_every,
                identities: self.identities,
                face_height_frac: self.face_height_frac,
                head_sway: self.head_sway,
                head_motion: self.head_motion,
                webcam: self.webcam,
            }),
            RenderBackend::Replay => BackendSettings::Replay {
                carriers: self.carriers,
            },
        };
        RenderSettings {
            width: self.width,
            height: self.height,
            gain: self.gain,
            viewing_distance_mm: self.viewing_distance_mm,
            natural_blinks: self.natural_blinks,
            preset: self.preset,
            crf: self.crf,
            jobs: self.jobs,
            backend,
        }
    }
}

/// The `[render]` table as written: every key of every backend, typed and
/// defaulted, before the keys are sorted by the backend they apply to.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
struct RenderTable {
    /// Video width in px; default: the canvas width.
    pub width: Option<usize>,
    /// Video height in px; default: the canvas height.
    pub height: Option<usize>,
    /// Amplification of the iris excursion (1 = the source's amplitude).
    pub gain: f64,
    /// Distance from the eyes to the screen, for vergence (mm).
    pub viewing_distance_mm: f64,
    /// Blink at a natural rate (besides the sources' own blinks).
    pub natural_blinks: bool,
    /// Draw each identity's eye where the extractor's iris model reads the
    /// trajectory's position (measured per session from probe frames;
    /// needs the models), rather than at the renderer's geometric position.
    pub match_extractor: bool,
    /// Full-face mode: after the probe, draw each session once, read that
    /// video back with the extractor (as `eyereplay extract` reads it),
    /// fit the response map and pose slopes to the session's own frames,
    /// and draw the session again through that fit, with the same head
    /// path. Needs `match_extractor`. About twice the drawing and one more
    /// read-back per session; off by default.
    pub match_readback: bool,
    /// With `match_readback`: the first pass draws, encodes and reads back
    /// every this many frames of the session (at its frame rate over this),
    /// 1-10. The fit needs the session's fixations, each several frames
    /// long, not every frame of each: 2 (the default) halves the first
    /// pass's cost with the same fidelity; 3 lets the extractor's tracker
    /// lag a turning head (docs/PERFORMANCE.md measures both).
    pub match_readback_every: usize,
    /// Face and close-up modes: how many crops the extractor reads each
    /// eye from, 1-9 (`eyereplay extract --iris-views`), in the
    /// `match_extractor` probe and in the evaluation's read-back of the
    /// session (recorded in its `_identity.json` as
    /// `extractor_iris_views`). 1 (default) is MediaPipe's single crop;
    /// more views read the eye more precisely for about as many times the
    /// iris model's CPU time.
    pub extractor_iris_views: usize,
    /// x264 preset.
    pub preset: String,
    /// x264 constant rate factor.
    pub crf: u32,
    /// Sessions rendered at once; 0 = one per core (our renderer) or one
    /// browser per two cores (the browser backend).
    pub jobs: usize,
    /// Which simulator draws the sessions: `eyes` (eyereplay's own
    /// ray-traced eyes, the default) or `browser` (a web page driven frame
    /// by frame in a headless Chromium, as the paper's stage 6 did) or
    /// `face` (a whole face from a real photo in a webcam frame, the head
    /// moving with the gaze) or `replay` (a real video of a person, their
    /// irises redrawn at the trajectory).
    pub backend: RenderBackend,
    /// `[render.browser]`: the browser backend's settings (page URL,
    /// viewport, canvas-to-page mapping, readiness, crop; see
    /// eyereplay-browser's README). Typed by the library when the backend is
    /// `browser`.
    pub browser: Option<toml::Table>,
    /// Where the page draws its eyes, for the visual-fidelity read-back of a
    /// browser-rendered video: per eye `[inner_x, inner_y, outer_x,
    /// outer_y]` in video px, image-left eye first. Without it, evaluation
    /// can only use the face detector.
    pub browser_eye_corners_px: Option<[[f64; 4]; 2]>,
    /// Full-face mode (`backend = "face"`): frontal photos whose faces
    /// become the identities (relative paths from the config's folder);
    /// empty = the bundled photos. Each class's sessions take them in turn
    /// (`SessionJob::balanced_choice` in eyereplay-render).
    pub identities: Vec<std::path::PathBuf>,
    /// Full-face mode: the face's forehead-to-chin height over the frame
    /// height, drawn per session from this range.
    pub face_height_frac: [f64; 2],
    /// Full-face mode: scale of the head's drift and sway (0 = none, 1 =
    /// the documented default RMS).
    pub head_sway: f64,
    /// Full-face mode: what moves the head. `model` (default): the eye-head
    /// coordination model plus drift and sway; `source`: where a session's
    /// frame comes from a video source, that video's own head pose at that
    /// moment (solved from its landmarks, relative to its median pose),
    /// the model elsewhere.
    pub head_motion: HeadMotion,
    /// `[render.webcam]`: the full-face mode's camera-look ranges (field of
    /// view, exposure, white balance, noise, blur, light, bitrate); typed
    /// by the library, defaults look like a laptop webcam.
    pub webcam: Option<toml::Table>,
    /// Real-face replay (`backend = "replay"`): videos of people facing the
    /// camera whose eyes are given the sessions' movements (relative paths
    /// from the config's folder); empty = the bundled sample carriers.
    /// Each class's sessions take them in turn, as with `identities`. The
    /// video keeps the carrier's size; `width`/`height` do not apply.
    pub carriers: Vec<std::path::PathBuf>,
}

/// What moves the full-face mode's head (`render.head_motion`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum HeadMotion {
    /// Eye-head coordination from the gaze, plus drift and sway.
    #[default]
    Model,
    /// A video source's own head pose where the frame comes from one.
    Source,
}

/// Which simulator renders the sessions.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RenderBackend {
    #[default]
    Eyes,
    Browser,
    /// A whole face from a real photo, head moving with the gaze, webcam
    /// look (eyereplay-face).
    Face,
    /// A real video of a person whose irises are redrawn at the session's
    /// trajectory (eyereplay-replay).
    Replay,
}

impl Default for RenderTable {
    fn default() -> Self {
        RenderTable {
            width: None,
            height: None,
            gain: 1.0,
            viewing_distance_mm: 600.0,
            natural_blinks: true,
            match_extractor: true,
            match_readback: false,
            match_readback_every: 2,
            extractor_iris_views: 1,
            preset: "veryfast".into(),
            crf: 18,
            jobs: 0,
            backend: RenderBackend::Eyes,
            browser: None,
            browser_eye_corners_px: None,
            identities: vec![],
            face_height_frac: [0.36, 0.5],
            head_sway: 1.0,
            head_motion: HeadMotion::Model,
            webcam: None,
            carriers: vec![],
        }
    }
}

/// The line of `path` that sets the `[render]` key an error names (its
/// first quoted word: `'backend': unknown variant ...`, or serde's
/// ``unknown field `urll` ``), under a `[render]` or `[render.*]` header or
/// written `render.key = ...`; `None` when the file cannot be read (a
/// config given as a Python dict) or holds no such line.
pub fn render_key_line(path: &Path, message: &str) -> Option<usize> {
    let quote = message.find(['\'', '`'])?;
    let q = message[quote..].chars().next()?;
    let key = message[quote + 1..].split(q).next()?;
    let text = std::fs::read_to_string(path).ok()?;
    let mut in_render = false;
    for (i, line) in text.lines().enumerate() {
        let l = line.trim();
        if l.starts_with('[') {
            let header = l.trim_start_matches('[').trim_end_matches(']').trim();
            in_render = header == "render" || header.starts_with("render.");
            continue;
        }
        let Some((k, _)) = l.split_once('=') else {
            continue;
        };
        let k = k.trim();
        if (in_render && k == key) || k.strip_prefix("render.") == Some(key) {
            return Some(i + 1);
        }
    }
    None
}

impl RenderSettings {
    /// The config's `[render]` table, typed (defaults where it is absent).
    /// `path` names the config in errors.
    pub fn from_config(cfg: &DatasetConfig, path: &Path) -> Result<Self, DatasetError> {
        match &cfg.render {
            None => Ok(RenderSettings::default()),
            Some(table) => Self::from_table(table).map_err(|e| {
                let message = eyereplay_prepare::describe_toml_error("", &e);
                // The table was parsed apart from the text, so its errors
                // carry no position: the key they name is looked up in
                // the file, as the rest of the config's errors give lines.
                let at = render_key_line(path, &message)
                    .map(|n| format!("line {n}: "))
                    .unwrap_or_default();
                DatasetError::invalid(path, format!("{at}[render]: {message}"))
            }),
        }
    }

    /// Deserializes the table; a type error names the key at fault (the
    /// table's own error does not), found by trying each key alone.
    fn from_table(table: &toml::Table) -> Result<Self, toml::de::Error> {
        let raw: RenderTable = toml::Value::Table(table.clone()).try_into().map_err(|e| {
            let key = table.iter().find(|(k, v)| {
                let mut one = toml::Table::new();
                one.insert((*k).clone(), (*v).clone());
                toml::Value::Table(one).try_into::<RenderTable>().is_err()
            });
            match key {
                Some((k, _)) => serde::de::Error::custom(format!("'{k}': {e}")),
                None => e,
            }
        })?;
        let backend = raw.backend;
        if let Some(key) = table
            .keys()
            .find(|k| *k != "backend" && !backend.keys().contains(&k.as_str()))
        {
            let owners: Vec<String> = [
                RenderBackend::Eyes,
                RenderBackend::Browser,
                RenderBackend::Face,
                RenderBackend::Replay,
            ]
            .into_iter()
            .filter(|b| b.keys().contains(&key.as_str()))
            .map(|b| format!("\"{}\"", b.name()))
            .collect();
            return Err(serde::de::Error::custom(format!(
                "'{key}' does not apply to backend = \"{}\" (only to {})",
                backend.name(),
                owners.join(" and ")
            )));
        }
        Ok(raw.into_settings())
    }

    /// Sessions to render at once: `jobs`, or one per core.
    pub fn jobs(&self) -> usize {
        if self.jobs > 0 {
            self.jobs
        } else {
            std::thread::available_parallelism()
                .map(|n| n.get())
                .unwrap_or(1)
        }
    }

    /// Sessions the backend renders at once, as it will render them:
    /// [`RenderSettings::jobs`] for the close-up eyes and the full face;
    /// `jobs`, or one browser per two cores (each keeps about two busy
    /// with its renderer and compositor); one for replay, which takes no
    /// `jobs` (each session decodes its carrier on every core). What
    /// `generate --dry-run` projects with.
    pub fn sessions_at_once(&self) -> usize {
        match self.backend.kind() {
            RenderBackend::Replay => 1,
            RenderBackend::Browser if self.jobs == 0 => {
                std::thread::available_parallelism().map_or(1, |n| (n.get() / 2).max(1))
            }
            _ => self.jobs(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cfg(render: &str) -> DatasetConfig {
        DatasetConfig::parse(&format!(
            "[classes.reading]\nsources = [{{ format = \"extract\", path = \"a.csv\" }}]\n{render}"
        ))
        .unwrap()
    }

    /// A `[render]` error gives the line of the key it names, as the rest
    /// of the config's errors do: the table itself carries no positions.
    #[test]
    fn render_errors_give_the_line_of_their_key() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("data.toml");
        let body = "[render]\nwidth = 320\nbackend = \"eye\"\n";
        let text = format!(
            "[classes.reading]\nsources = [{{ format = \"extract\", path = \"a.csv\" }}]\n{body}"
        );
        std::fs::write(&p, &text).unwrap();
        let e = RenderSettings::from_config(&DatasetConfig::parse(&text).unwrap(), &p)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("data.toml: line 5: [render]: 'backend'") && e.contains("'eyes'"),
            "{e}"
        );
        // Dotted, at the top level.
        let text = "render.crf = \"high\"\n[classes.reading]\nsources = [{ format = \"extract\", path = \"a.csv\" }]\n";
        std::fs::write(&p, text).unwrap();
        let e = RenderSettings::from_config(&DatasetConfig::parse(text).unwrap(), &p)
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 1: [render]: 'crf'"), "{e}");
    }

    #[test]
    fn typed_with_defaults_and_real_errors() {
        let p = Path::new("data.toml");
        assert_eq!(
            RenderSettings::from_config(&cfg(""), p).unwrap(),
            RenderSettings::default()
        );
        let s = RenderSettings::from_config(&cfg("[render]\ngain = 2.0\njobs = 3"), p).unwrap();
        assert_eq!((s.gain, s.jobs, s.crf), (2.0, 3, 18));
        let s = RenderSettings::from_config(
            &cfg("[render]\nbackend = \"face\"\nhead_motion = \"source\""),
            p,
        )
        .unwrap();
        let BackendSettings::Face(f) = s.backend else {
            panic!("not face: {s:?}")
        };
        assert_eq!(f.head_motion, HeadMotion::Source);
        let e = RenderSettings::from_config(
            &cfg("[render]\nbackend = \"face\"\nhead_motion = \"video\""),
            p,
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("head_motion") && e.contains("source"), "{e}");
        let e = RenderSettings::from_config(&cfg("[render]\ngian = 2.0"), p)
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("data.toml: [render]:") && e.contains("gian"),
            "{e}"
        );
        let e = RenderSettings::from_config(&cfg("[render]\ncrf = \"high\""), p)
            .unwrap_err()
            .to_string();
        assert!(e.contains("data.toml") && e.contains("crf"), "{e}");
    }

    #[test]
    fn a_key_of_another_backend_is_an_error_naming_it() {
        let p = Path::new("data.toml");
        let e = RenderSettings::from_config(&cfg("[render]\ncarriers = [\"a.mp4\"]"), p)
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "data.toml: [render]: 'carriers' does not apply to backend = \"eyes\" (only to \"replay\")"
        );
        let e = RenderSettings::from_config(&cfg("[render]\nbackend = \"replay\"\nwidth = 640"), p)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("'width' does not apply to backend = \"replay\""),
            "{e}"
        );
        // Every key of the raw table applies to at least one backend.
        let all = toml::Value::try_from(RenderTable::default()).unwrap();
        for key in all.as_table().unwrap().keys().filter(|k| *k != "backend") {
            assert!(
                [
                    RenderBackend::Eyes,
                    RenderBackend::Browser,
                    RenderBackend::Face,
                    RenderBackend::Replay
                ]
                .iter()
                .any(|b| b.keys().contains(&key.as_str())),
                "{key} applies to no backend"
            );
        }
    }
}
