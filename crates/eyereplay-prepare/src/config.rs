//! The dataset config (TOML). Defaults are the paper's: N = 72 sessions per
//! class, F = 7500 frames (300 s at 25 fps), a 1280x720 canvas, speed scales
//! 1.05 (reading) / 1.0 (conversation). Unknown keys are rejected with the
//! nearest valid key suggested.

use crate::error::{ConfigError, PrepareError};
use eyereplay_behaviour::GeneratorSpec;
use eyereplay_core::{Canvas, GazeClass};
use eyereplay_signal::EdgeGaussParams;
use eyereplay_sources::{ReadOptions, SourceSpec};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DatasetConfig {
    /// Frame rate of sessions and videos.
    #[serde(default = "d_fps")]
    pub fps: f64,
    /// Frames per session (the paper's F).
    #[serde(default = "d_frames")]
    pub session_frames: usize,
    #[serde(default)]
    pub canvas: Canvas,
    /// Seed for every random choice downstream (renderer identities).
    #[serde(default)]
    pub seed: u64,
    #[serde(default)]
    pub calibration: CalibrationConfig,
    #[serde(default)]
    pub blink_filter: BlinkFilterConfig,
    #[serde(default)]
    pub smoothing: SmoothingConfig,
    #[serde(default)]
    pub resample: ResampleConfig,
    #[serde(default)]
    pub read: ReadOptions,
    /// Classes by name (`reading`, `conversation`).
    pub classes: BTreeMap<GazeClass, ClassConfig>,
    /// Rendering settings, read by `eyereplay generate` (the renderer's
    /// options; kept as a table here so trajectory preparation does not
    /// depend on the renderer).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub render: Option<toml::Table>,
    /// Folder that relative source paths are relative to (the config's).
    #[serde(skip)]
    pub base_dir: PathBuf,
}

fn d_fps() -> f64 {
    25.0
}
fn d_frames() -> usize {
    7500
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClassConfig {
    /// Sessions to cut (the paper's N).
    #[serde(default = "d_sessions")]
    pub sessions: usize,
    /// Scale about the class centroid before slicing; default 1.05 for
    /// reading, 1.0 for conversation.
    #[serde(default)]
    pub speed_scale: Option<f64>,
    /// Real recordings; may be empty when `generators` make the class.
    #[serde(default)]
    pub sources: Vec<SourceSpec>,
    /// Behaviour models (docs/BEHAVIOUR.md): synthetic people whose gaze
    /// is generated, one recording each, pooled after the real sources.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub generators: Vec<GeneratorSpec>,
}

fn d_sessions() -> usize {
    72
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum CalibrationMode {
    /// 5th-95th percentile range of each axis to 80 % of the canvas extent,
    /// centred (paper appendix).
    #[default]
    Auto,
    /// `s_x, s_y, mu_x, mu_y` as given.
    Manual,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum CalibrationScope {
    /// One calibration over every source of every class: keeps the classes'
    /// amplitudes relative to each other (reading is smaller than conversation).
    #[default]
    Pooled,
    /// One calibration per source, as if each filled the canvas alone.
    PerSource,
}

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CalibrationConfig {
    pub mode: CalibrationMode,
    pub scope: CalibrationScope,
    pub low_percentile: f64,
    pub high_percentile: f64,
    /// Fraction of the canvas extent the percentile range fills.
    pub fill_fraction: f64,
    pub s_x: Option<f64>,
    pub s_y: Option<f64>,
    pub mu_x: Option<f64>,
    pub mu_y: Option<f64>,
}

impl Default for CalibrationConfig {
    fn default() -> Self {
        CalibrationConfig {
            mode: CalibrationMode::Auto,
            scope: CalibrationScope::Pooled,
            low_percentile: 5.0,
            high_percentile: 95.0,
            fill_fraction: 0.8,
            s_x: None,
            s_y: None,
            mu_x: None,
            mu_y: None,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BlinkFilterConfig {
    /// Values outside [Q1 - k IQR, Q3 + k IQR] are blink artifacts.
    pub iqr_k: f64,
    /// Which sources the IQR rule applies to. Invalid and blink-flagged
    /// samples are filled for every source. Default `video`: eye trackers
    /// flag blinks themselves, and their real wide saccades lie outside
    /// 3 IQR of a fixation-dominated distribution (on the test data's
    /// `both_eyes.asc`, 9 % of all samples).
    pub iqr_applies_to: AppliesTo,
    /// What a sample with one axis outside its fence loses: only that axis
    /// (`per_axis`, the paper's rule) or both (`joint`, better on webcam
    /// extractions: docs/PIPELINE.md, "Blink filtering").
    pub fill: crate::FillAxes,
}

impl Default for BlinkFilterConfig {
    fn default() -> Self {
        BlinkFilterConfig {
            iqr_k: 3.0,
            iqr_applies_to: AppliesTo::Video,
            fill: crate::FillAxes::PerAxis,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum SmoothingMethod {
    #[default]
    EdgeGauss,
    None,
}

/// Which sources a filtering step applies to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum AppliesTo {
    /// Only landmark-based video sources (jittery, spiky); eye trackers are clean.
    #[default]
    Video,
    All,
}

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SmoothingConfig {
    pub method: SmoothingMethod,
    pub apply_to: AppliesTo,
    pub sigma_s: f64,
    pub window_s: f64,
    pub z: f64,
    /// Smallest step kept sharp, in canvas px.
    pub min_step_px: f64,
}

impl Default for SmoothingConfig {
    fn default() -> Self {
        let p = EdgeGaussParams::default();
        SmoothingConfig {
            method: SmoothingMethod::EdgeGauss,
            apply_to: AppliesTo::Video,
            sigma_s: p.sigma_s,
            window_s: p.window_s,
            z: p.z,
            min_step_px: p.min_step,
        }
    }
}

impl SmoothingConfig {
    pub fn params(&self) -> EdgeGaussParams {
        EdgeGaussParams {
            sigma_s: self.sigma_s,
            window_s: self.window_s,
            z: self.z,
            min_step: self.min_step_px,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum SpeedCorrection {
    /// Applied to sources sampled at most `linear_max_ratio` times the
    /// target rate (webcam video, the case the paper designed it for).
    #[default]
    Auto,
    Always,
    Never,
}

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ResampleConfig {
    pub speed_correction: SpeedCorrection,
    /// Sources faster than this multiple of the target rate are low-pass
    /// filtered and decimated instead of linearly interpolated.
    pub linear_max_ratio: f64,
    /// Gain of that low-pass at the target's Nyquist frequency.
    pub antialias_stop_gain: f64,
}

impl Default for ResampleConfig {
    fn default() -> Self {
        ResampleConfig {
            speed_correction: SpeedCorrection::Auto,
            linear_max_ratio: 2.0,
            antialias_stop_gain: eyereplay_signal::ANTIALIAS_STOP_GAIN,
        }
    }
}

/// The longest session a config may ask for, in frames: 10 million, about
/// 111 hours at 25 fps.
pub const MAX_SESSION_FRAMES: usize = 10_000_000;

impl DatasetConfig {
    /// Reads and validates a config; relative source paths are resolved
    /// against the config file's folder.
    pub fn load(path: &Path) -> Result<Self, PrepareError> {
        let text = std::fs::read_to_string(path).map_err(|e| PrepareError::Config {
            path: path.into(),
            message: e.to_string(),
        })?;
        Self::from_text(&text, path, path.parent().unwrap_or(Path::new(".")))
    }

    /// Parses and validates config text that did not come from a file (a
    /// Python dict, say): errors name `label` where [`load`](Self::load)
    /// names the file, and relative source paths resolve against `base_dir`.
    pub fn from_text(text: &str, label: &Path, base_dir: &Path) -> Result<Self, PrepareError> {
        let config_error = |e: ConfigError| PrepareError::Config {
            path: label.into(),
            message: e.to_string(),
        };
        let mut cfg = Self::parse(text).map_err(config_error)?;
        cfg.base_dir = base_dir.to_path_buf();
        cfg.validate().map_err(config_error)?;
        Ok(cfg)
    }

    /// Parses TOML text; errors are one line with position and, for an
    /// unknown key, the nearest valid one.
    pub fn parse(text: &str) -> Result<Self, ConfigError> {
        toml::from_str::<DatasetConfig>(text)
            .map_err(|e| ConfigError::Parse(describe_toml_error(text, &e)))
    }

    /// A source path as written in the config, resolved against the
    /// config's folder. Paths stay as written in the config itself (and so in
    /// `metadata.json`), which keeps metadata identical across checkouts.
    pub fn resolve(&self, p: &Path) -> PathBuf {
        if p.is_relative() {
            self.base_dir.join(p)
        } else {
            p.to_path_buf()
        }
    }

    /// The spec with its path resolved, ready to read.
    pub fn resolved_spec(&self, spec: &SourceSpec) -> SourceSpec {
        let mut s = spec.clone();
        *s.path_mut() = self.resolve(spec.path());
        s
    }

    /// Rejects values out of range and classes with nothing to draw from;
    /// the message is one line.
    pub fn validate(&self) -> Result<(), ConfigError> {
        if !self.fps.is_finite() || self.fps <= 0.0 {
            return Err(ConfigError::Invalid(format!(
                "fps must be a positive number, got {}",
                self.fps
            )));
        }
        if self.session_frames == 0 {
            return Err(ConfigError::Invalid(
                "session_frames must be at least 1 (the paper uses 7500)".into(),
            ));
        }
        // A session is held in memory whole (16 bytes a frame, more while
        // it is drawn): past this, a typo's extra zeros would end in an
        // allocation failure instead of a message.
        if self.session_frames > MAX_SESSION_FRAMES {
            return Err(ConfigError::Invalid(format!(
                "session_frames must be at most {MAX_SESSION_FRAMES} (about {:.0} h at {} fps), got {}",
                MAX_SESSION_FRAMES as f64 / self.fps / 3600.0,
                self.fps,
                self.session_frames
            )));
        }
        if self.canvas.width_px == 0 || self.canvas.height_px == 0 {
            return Err(ConfigError::Invalid(
                "canvas width_px and height_px must be positive".into(),
            ));
        }
        if self.classes.is_empty() {
            return Err(ConfigError::Invalid(
                "no classes: add [classes.reading] and/or [classes.conversation] with sources"
                    .into(),
            ));
        }
        let c = &self.calibration;
        let ordered = (0.0..100.0).contains(&c.low_percentile)
            && c.low_percentile < c.high_percentile
            && c.high_percentile <= 100.0;
        if !ordered {
            return Err(ConfigError::Invalid(
                "calibration percentiles must satisfy 0 <= low < high <= 100".into(),
            ));
        }
        if c.fill_fraction.is_nan() || c.fill_fraction <= 0.0 || c.fill_fraction > 1.0 {
            return Err(ConfigError::Invalid(
                "calibration.fill_fraction must be in (0, 1]".into(),
            ));
        }
        if c.mode == CalibrationMode::Manual {
            for (k, v) in [
                ("s_x", c.s_x),
                ("s_y", c.s_y),
                ("mu_x", c.mu_x),
                ("mu_y", c.mu_y),
            ] {
                let Some(v) = v else {
                    return Err(ConfigError::Invalid(format!(
                        "calibration.mode = \"manual\" needs calibration.{k}"
                    )));
                };
                // What `evaluate` would refuse in metadata.json, refused
                // here before a dataset is written: a zero scale puts every
                // sample on one point.
                if !v.is_finite() || (k.starts_with("s_") && v == 0.0) {
                    return Err(ConfigError::Invalid(format!(
                        "calibration.{k} must be a finite number{}, got {v}",
                        if k.starts_with("s_") {
                            " other than 0"
                        } else {
                            ""
                        }
                    )));
                }
            }
        }
        let positive = |name: &str, v: f64| -> Result<(), ConfigError> {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(ConfigError::Invalid(format!(
                    "{name} must be a positive number, got {v}"
                )))
            }
        };
        // Zero or negative values here do not fail: they loop (a gap of 0
        // s splits a recording at every sample) or smooth nothing.
        positive("read.max_gap_s", self.read.max_gap_s)?;
        positive("read.eye_gains.nx_per_deg", self.read.eye_gains.nx_per_deg)?;
        positive("read.eye_gains.ny_per_deg", self.read.eye_gains.ny_per_deg)?;
        positive("smoothing.sigma_s", self.smoothing.sigma_s)?;
        positive("smoothing.window_s", self.smoothing.window_s)?;
        positive("smoothing.z", self.smoothing.z)?;
        if !(self.smoothing.min_step_px.is_finite() && self.smoothing.min_step_px >= 0.0) {
            return Err(ConfigError::Invalid(format!(
                "smoothing.min_step_px must be 0 or more, got {}",
                self.smoothing.min_step_px
            )));
        }
        if !(self.resample.linear_max_ratio.is_finite() && self.resample.linear_max_ratio >= 1.0) {
            return Err(ConfigError::Invalid(format!(
                "resample.linear_max_ratio must be at least 1, got {}",
                self.resample.linear_max_ratio
            )));
        }
        let g = self.resample.antialias_stop_gain;
        if !(g > 0.0 && g < 1.0) {
            return Err(ConfigError::Invalid(format!(
                "resample.antialias_stop_gain must be between 0 and 1 (exclusive), got {g}"
            )));
        }
        positive("blink_filter.iqr_k", self.blink_filter.iqr_k)?;
        for (class, cc) in &self.classes {
            if cc.sessions == 0 {
                return Err(ConfigError::Invalid(format!(
                    "classes.{class}.sessions must be at least 1"
                )));
            }
            if cc.sources.is_empty() && cc.generators.is_empty() {
                return Err(ConfigError::Invalid(format!(
                    "classes.{class} has no sources and no generators (add sources = [...] or [[classes.{class}.generators]])"
                )));
            }
            for (i, g) in cc.generators.iter().enumerate() {
                let at = format!("classes.{class}.generators[{i}]");
                g.validate(&at)?;
                // A read answer is never cut below the shortest (the
                // interview model ends in talk instead), so one longer
                // than the person's whole gaze would leave only those who
                // start reading ever reading.
                if g.model == eyereplay_behaviour::Model::Interview {
                    let read_s = g.interview.clone().unwrap_or_default().read_s;
                    let duration_s = g.duration_s.unwrap_or_else(|| self.default_generated_s());
                    if read_s[0] > duration_s {
                        return Err(ConfigError::Invalid(format!(
                            "{at}: interview.read_s starts at {} s, longer than each person's {} s \
                             of gaze (duration_s, else one session): no read answer would fit",
                            eyereplay_core::show_number(read_s[0]),
                            eyereplay_core::show_number(duration_s)
                        )));
                    }
                }
            }
            if let Some(s) = cc.speed_scale {
                if !s.is_finite() || s <= 0.0 {
                    return Err(ConfigError::Invalid(format!(
                        "classes.{class}.speed_scale must be positive"
                    )));
                }
            }
        }
        Ok(())
    }

    pub fn speed_scale(&self, class: GazeClass) -> f64 {
        self.classes
            .get(&class)
            .and_then(|c| c.speed_scale)
            .unwrap_or(class.default_speed_scale())
    }

    /// Every source path (and every generator's text file), for
    /// validation before any work starts.
    pub fn source_paths(&self) -> Vec<PathBuf> {
        self.classes
            .values()
            .flat_map(|c| {
                c.sources.iter().map(|s| self.resolve(s.path())).chain(
                    c.generators
                        .iter()
                        .filter_map(|g| g.text.as_deref().map(|t| self.resolve(t))),
                )
            })
            .collect()
    }

    /// Whether any class has a behaviour model.
    pub fn has_generators(&self) -> bool {
        self.classes.values().any(|c| !c.generators.is_empty())
    }

    /// Seconds of each generated person by default: one session and one
    /// frame more, so that with only generated sources each session is one
    /// whole person (the slicing stride is then exactly a person).
    pub fn default_generated_s(&self) -> f64 {
        (self.session_frames + 1) as f64 / self.fps
    }
}

/// Turns a toml/serde error into one line: `line L, column C: message`,
/// plus `(did you mean 'x'?)` for unknown keys and variants.
pub fn describe_toml_error(text: &str, e: &toml::de::Error) -> String {
    let msg = plain_types(&e.message().replace('\n', " "));
    let pos = e.span().map(|span| {
        let before = &text[..span.start.min(text.len())];
        let line = before.matches('\n').count() + 1;
        let col = before.len() - before.rfind('\n').map_or(0, |i| i + 1) + 1;
        // serde names the value's type, not its key: the key is on the
        // value's line (a dict given to the Python package has no lines
        // of its own to look at).
        let key = msg
            .starts_with("invalid ")
            .then(|| key_at(text, span.start))
            .flatten()
            .map(|k| format!("{k}: "))
            .unwrap_or_default();
        format!("line {line}, column {col}: {key}")
    });
    let mut out = format!("{}{}", pos.unwrap_or_default(), msg.trim());
    if let Some(s) = suggestion(&msg) {
        out.push_str(&format!(" (did you mean '{s}'?)"));
    } else if msg.contains("invalid inline table") {
        // The usual cause: a source's `{ ... }` broken over lines, which
        // TOML 1.0 does not allow.
        out.push_str(
            " (an inline table `{ ... }` must stay on one line; for a long source write \
             [[classes.NAME.sources]] and one key a line below it)",
        );
    } else if msg.contains("missing field `format`") {
        // A source's `format` picks its kind, so serde sees a misspelt
        // `format` as the tag missing, not as an unknown key: find it in
        // the source's own text.
        let region = e
            .span()
            .and_then(|span| text.get(span.start.min(text.len())..span.end.min(text.len())))
            .unwrap_or("");
        match misspelt_format_key(region) {
            Some(key) => out.push_str(&format!(" (is '{key}' meant to be 'format'?)")),
            None => out.push_str(" (every source names its kind: format = \"video\", \"eyelink\", \"fixations\", ...)"),
        }
    }
    out
}

/// The dotted key whose value starts at byte `start` of `text`: the
/// `key = ` on its line, under the nearest `[table]` header above it.
/// `None` inside an inline table or an array, where the line's key is not
/// the value's.
fn key_at(text: &str, start: usize) -> Option<String> {
    let start = start.min(text.len());
    let line_start = text[..start].rfind('\n').map_or(0, |i| i + 1);
    let line = text[line_start..].split('\n').next()?;
    let (key, value) = line.split_once('=')?;
    let key = key.trim();
    let simple = |c: char| c.is_ascii_alphanumeric() || "_-.\"".contains(c);
    if key.is_empty() || !key.chars().all(simple) || value.trim_start().starts_with(['{', '[']) {
        return None;
    }
    let header = text[..line_start].lines().rev().find_map(|l| {
        let l = l.trim();
        l.strip_prefix("[[")
            .and_then(|r| r.strip_suffix("]]"))
            .or_else(|| l.strip_prefix('[').and_then(|r| r.strip_suffix(']')))
    });
    Some(match header {
        Some(h) => format!("{}.{key}", h.trim()),
        None => key.to_string(),
    })
}

/// serde's Rust type names ("expected usize") in words a config's author
/// reads.
fn plain_types(msg: &str) -> String {
    let mut out = msg.to_string();
    for (rust, words) in [
        ("usize", "a whole number, 0 or more"),
        ("u64", "a whole number, 0 or more"),
        ("u32", "a whole number, 0 or more"),
        ("u16", "a whole number, 0 or more"),
        ("u8", "a whole number, 0 or more"),
        ("i64", "a whole number"),
        ("i32", "a whole number"),
        ("f64", "a number"),
        ("f32", "a number"),
    ] {
        out = out.replace(&format!("expected {rust}"), &format!("expected {words}"));
    }
    out
}

/// A key of the inline table `region` (`{ formt = "eyelink", path = ... }`)
/// within two edits of `format` but not it.
fn misspelt_format_key(region: &str) -> Option<&str> {
    region
        .split(['{', ',', '\n'])
        .filter_map(|part| part.split_once('=').map(|(k, _)| k.trim()))
        .find(|k| {
            let d = strsim::damerau_levenshtein(k, "format");
            (1..=2).contains(&d)
        })
}

/// For serde's "unknown field `x`, expected one of `a`, `b`" (and "unknown
/// variant"), the expected name closest to `x`.
fn suggestion(msg: &str) -> Option<String> {
    let rest = msg
        .split_once("unknown field `")
        .or_else(|| msg.split_once("unknown variant `"))?
        .1;
    let (bad, expected) = rest.split_once('`')?;
    let names: Vec<&str> = expected.split('`').skip(1).step_by(2).collect();
    names
        .iter()
        .map(|n| (strsim::damerau_levenshtein(bad, n), *n))
        .filter(|(d, n)| *d <= (n.len().max(bad.len()) / 2).max(2))
        .min()
        .map(|(_, n)| n.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_value_of_the_wrong_type_names_its_key_in_words() {
        let err = |text: &str| DatasetConfig::parse(text).unwrap_err().to_string();
        let classes = "[classes.reading]\nsources = [{ format = \"extract\", path = \"a.csv\" }]\n";
        let e = err(&format!("session_frames = \"50\"\n{classes}"));
        assert!(
            e.contains("line 1, column 18: session_frames: invalid type: string \"50\", expected a whole number, 0 or more"),
            "{e}"
        );
        let e = err(&format!("{classes}[smoothing]\nsigma_s = \"x\"\n"));
        assert!(
            e.contains("smoothing.sigma_s: invalid type: string \"x\", expected a number"),
            "{e}"
        );
    }

    #[test]
    fn paper_defaults() {
        let c = DatasetConfig::parse(
            "[classes.reading]\nsources = [{ format = \"extract\", path = \"a.csv\" }]\n",
        )
        .unwrap();
        assert_eq!(c.fps, 25.0);
        assert_eq!(c.session_frames, 7500);
        assert_eq!(
            c.canvas,
            Canvas {
                width_px: 1280,
                height_px: 720
            }
        );
        assert_eq!(c.classes[&GazeClass::Reading].sessions, 72);
        assert_eq!(c.speed_scale(GazeClass::Reading), 1.05);
        assert_eq!(c.speed_scale(GazeClass::Conversation), 1.0);
        assert_eq!(c.calibration.fill_fraction, 0.8);
        assert_eq!(c.blink_filter.iqr_k, 3.0);
    }

    /// A source's inline table broken over lines is refused by TOML 1.0;
    /// the error names the way that works, which parses to the same source.
    #[test]
    fn a_multi_line_inline_table_points_to_the_array_of_tables() {
        let e = DatasetConfig::parse(
            "[classes.reading]\nsources = [{ format = \"extract\",\n  path = \"a.csv\" }]\n",
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("line 2") && e.contains("[[classes.NAME.sources]]"),
            "{e}"
        );
        let tables = DatasetConfig::parse(
            "[[classes.reading.sources]]\nformat = \"extract\"\npath = \"a.csv\"\n",
        )
        .unwrap();
        let inline = DatasetConfig::parse(
            "[classes.reading]\nsources = [{ format = \"extract\", path = \"a.csv\" }]\n",
        )
        .unwrap();
        assert_eq!(tables.classes, inline.classes);
    }

    #[test]
    fn unknown_key_suggests_nearest() {
        let e = DatasetConfig::parse("[classes.reading]\nsesions = 3\nsources = []\n")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("line 2") && e.contains("did you mean 'sessions'"),
            "{e}"
        );
        let e = DatasetConfig::parse("sesion_frames = 3\n[classes.reading]\nsources = []\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("did you mean 'session_frames'"), "{e}");
        let e = DatasetConfig::parse(
            "[classes.reading]\nsources = [{ format = \"eyelnk\", path = \"a\" }]\n",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("did you mean 'eyelink'"), "{e}");
        assert!(!e.contains('\n'));
        // A misspelt tag reads as the tag missing: the key is named.
        let e = DatasetConfig::parse(
            "[classes.reading]\nsources = [{ formt = \"eyelink\", path = \"a\" }]\n",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("is 'formt' meant to be 'format'?"), "{e}");
        let e = DatasetConfig::parse("[classes.reading]\nsources = [{ path = \"a\" }]\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("every source names its kind"), "{e}");
    }

    #[test]
    fn zero_sessions_and_frames_rejected() {
        let mut c = DatasetConfig::parse(
            "session_frames = 0\n[classes.reading]\nsources = [{ format = \"extract\", path = \"a.csv\" }]\n",
        )
        .unwrap();
        assert!(c
            .validate()
            .unwrap_err()
            .to_string()
            .contains("session_frames"));
        c.session_frames = 10;
        c.classes.get_mut(&GazeClass::Reading).unwrap().sessions = 0;
        assert!(c.validate().unwrap_err().to_string().contains("sessions"));
    }

    #[test]
    fn an_interview_answer_longer_than_the_person_is_refused() {
        // 250 frames at 25 fps: people of 251 / 25 = 10.04 s by default.
        let cfg = |read: &str| {
            DatasetConfig::parse(&format!(
                "session_frames = 250\n[classes.reading]\n[[classes.reading.generators]]\n\
                 model = \"interview\"\ninterview = {{ read_s = {read} }}\n"
            ))
            .unwrap()
        };
        let e = cfg("[20.0, 60.0]").validate().unwrap_err().to_string();
        assert!(
            e.contains("classes.reading.generators[0]: interview.read_s starts at 20 s, longer than each person's 10.04 s"),
            "{e}"
        );
        assert!(cfg("[5.0, 60.0]").validate().is_ok());
    }

    /// Values that used to loop, allocate terabytes or pass silently are
    /// refused by name, in one line; the defaults pass.
    #[test]
    fn out_of_range_numbers_are_named() {
        let base = "[classes.reading]\nsources = [{ format = \"extract\", path = \"a.csv\" }]\n";
        assert!(DatasetConfig::parse(base).unwrap().validate().is_ok());
        for (line, name) in [
            ("session_frames = 100000000000", "session_frames"),
            ("[read]\nmax_gap_s = 0.0", "read.max_gap_s"),
            ("[read]\nmax_gap_s = -1.0", "read.max_gap_s"),
            (
                "[read]\neye_gains = { nx_per_deg = 0.0, ny_per_deg = 0.01 }",
                "nx_per_deg",
            ),
            ("[smoothing]\nsigma_s = -1.0", "smoothing.sigma_s"),
            ("[smoothing]\nwindow_s = 0.0", "smoothing.window_s"),
            ("[smoothing]\nz = -1.0", "smoothing.z"),
            ("[smoothing]\nz = nan", "smoothing.z"),
            ("[smoothing]\nmin_step_px = -2.0", "smoothing.min_step_px"),
            ("[resample]\nlinear_max_ratio = 0.5", "linear_max_ratio"),
            (
                "[resample]\nantialias_stop_gain = 1.0",
                "antialias_stop_gain",
            ),
            ("[blink_filter]\niqr_k = nan", "blink_filter.iqr_k"),
        ] {
            // Top-level keys go before the first table.
            let text = if line.starts_with('[') {
                format!("{base}{line}\n")
            } else {
                format!("{line}\n{base}")
            };
            let e = DatasetConfig::parse(&text)
                .unwrap()
                .validate()
                .expect_err(line)
                .to_string();
            assert!(e.contains(name), "{line}: {e}");
            assert!(!e.contains('\n'), "{e}");
        }
    }
}
