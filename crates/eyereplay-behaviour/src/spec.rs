//! The `generators` tables of a dataset config: which model, how many
//! synthetic people, and the ranges each person's parameters are drawn
//! from. Every range is `[low, high]`, drawn uniformly per person (seeded);
//! the drawn values go to the dataset's `metadata.json`, so a user can
//! train on one range and test on another.

use crate::geometry::Surface;
use crate::BehaviourError;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// `[low, high]`, drawn uniformly.
pub type Range = [f64; 2];

/// Which behaviour a generator makes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Model {
    /// Reading a text on a surface.
    Reading,
    /// Talking with someone on the screen.
    Conversation,
    /// An interview: free answers and read answers in turn, with per-frame
    /// reading labels.
    Interview,
}

impl Model {
    pub fn name(self) -> &'static str {
        match self {
            Model::Reading => "reading",
            Model::Conversation => "conversation",
            Model::Interview => "interview",
        }
    }
}

/// One `[[classes.<class>.generators]]` table.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GeneratorSpec {
    pub model: Model,
    /// Synthetic people, one recording each; default: the class's sessions.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub people: Option<usize>,
    /// Length of each person's recording, s; default: one session.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub duration_s: Option<f64>,
    /// A UTF-8 text file to read (reading, interview); default: the bundled
    /// public-domain text.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub text: Option<PathBuf>,
    /// Surfaces a reader may read from, one drawn per person.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub surfaces: Option<Vec<Surface>>,
    /// Overrides of the surface presets' physical ranges.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub layout: Option<LayoutRanges>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reader: Option<ReaderRanges>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub talker: Option<TalkerRanges>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub eye: Option<EyeRanges>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub interview: Option<InterviewRanges>,
}

/// Physical layout ranges that replace a surface preset's.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LayoutRanges {
    pub distance_mm: Option<Range>,
    pub offset_x_mm: Option<Range>,
    pub offset_y_mm: Option<Range>,
    pub char_width_mm: Option<Range>,
    pub line_chars: Option<Range>,
    pub lines_per_page: Option<Range>,
}

/// Reading parameters (module `reading` has the model and sources).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ReaderRanges {
    /// Chance that a person reads aloud.
    pub aloud_prob: f64,
    pub fixation_mean_ms: Range,
    pub fixation_shape: Range,
    pub regression_prob: Range,
    pub refixation_per_char: Range,
    pub skip_scale: Range,
    pub corrective_prob: Range,
    pub undersweep_ms: Range,
    pub blinks_per_min: Range,
}

impl Default for ReaderRanges {
    fn default() -> Self {
        ReaderRanges {
            aloud_prob: 0.3,
            // OneStop readers 170 and 218 ms; Rayner 1998: 225 ms silent.
            fixation_mean_ms: [170.0, 240.0],
            // OneStop: 6.9 and 8.0.
            fixation_shape: [6.0, 9.0],
            // ZuCo readers 0.05-0.25; Rayner 1998 10-15 %.
            regression_prob: [0.06, 0.2],
            refixation_per_char: [0.08, 0.2],
            // OneStop first-pass skipping 31 and 64 %.
            skip_scale: [0.8, 1.6],
            corrective_prob: [0.35, 0.55],
            undersweep_ms: [138.0, 176.0],
            // Doughty 2001: 1.4-14.4 a minute while reading.
            blinks_per_min: [2.0, 12.0],
        }
    }
}

/// Conversation parameters (module `conversation`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TalkerRanges {
    /// The partner's face below the camera, deg.
    pub partner_below_deg: Range,
    pub partner_side_deg: Range,
    pub face_share_listening: Range,
    pub face_share_speaking: Range,
    pub face_dwell_listening_s: Range,
    pub face_dwell_speaking_s: Range,
    pub speaking_turn_s: Range,
    pub listening_turn_s: Range,
    pub aversion_deg: Range,
    pub cognitive_aversion_prob: Range,
    pub face_scan_s: Range,
    pub nods_per_s: Range,
    pub nod_deg: Range,
    pub eye_preference: Range,
    pub head_sway_deg: Range,
    pub blinks_per_min: Range,
}

impl Default for TalkerRanges {
    fn default() -> Self {
        TalkerRanges {
            partner_below_deg: [4.0, 12.0],
            partner_side_deg: [-4.0, 4.0],
            // Argyle & Ingham 75 / 41 %; Guy & Pertzov 76-84 % in interviews.
            face_share_listening: [0.65, 0.88],
            face_share_speaking: [0.35, 0.6],
            face_dwell_listening_s: [1.5, 4.0],
            face_dwell_speaking_s: [1.0, 3.0],
            speaking_turn_s: [5.0, 15.0],
            listening_turn_s: [3.0, 10.0],
            aversion_deg: [3.0, 9.0],
            cognitive_aversion_prob: [0.6, 0.8],
            face_scan_s: [0.2, 0.45],
            nods_per_s: [0.05, 0.25],
            nod_deg: [0.5, 1.5],
            eye_preference: [0.4, 0.9],
            head_sway_deg: [0.25, 0.75],
            // Bentivoglio 26 / min; Doughty 10.5-32.5.
            blinks_per_min: [10.0, 32.0],
        }
    }
}

/// Oculomotor parameters every model shares.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EyeRanges {
    /// Dai et al. 2016 main sequence: 600 / 6 (code), ~460 / 9 (Hopf 2018).
    pub eta_deg_per_s: Range,
    pub c_deg: Range,
    /// Fixational drift, deg^2/s.
    pub drift_deg2_per_s: Range,
    /// Yuval-Greenberg et al. 2014: 2-3 Hz (fewer in reading fixations).
    pub microsaccade_hz: Range,
    pub microsaccade_deg: Range,
    /// Slow postural drift of the head (0.02-0.1 Hz) that the eyes
    /// counter-rotate, deg.
    pub posture_deg: Range,
}

impl Default for EyeRanges {
    fn default() -> Self {
        EyeRanges {
            eta_deg_per_s: [450.0, 620.0],
            c_deg: [6.0, 9.0],
            drift_deg2_per_s: [0.002, 0.01],
            microsaccade_hz: [0.5, 2.5],
            microsaccade_deg: [0.15, 0.5],
            posture_deg: [0.5, 3.0],
        }
    }
}

/// How an interview alternates talking and reading.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct InterviewRanges {
    /// Length of a free-talk stretch (a question heard, an answer given), s.
    pub talk_s: Range,
    /// Length of a read answer, s. The recording's end never cuts one
    /// below the low end: a session ends in talk rather than a second into
    /// an answer.
    pub read_s: Range,
    /// Chance of a glance at the camera at each line end while reading.
    pub glance_prob: Range,
    /// Chance that the session starts with reading rather than talk.
    pub start_reading_prob: f64,
}

impl Default for InterviewRanges {
    fn default() -> Self {
        InterviewRanges {
            talk_s: [8.0, 30.0],
            read_s: [8.0, 30.0],
            glance_prob: [0.0, 0.3],
            start_reading_prob: 0.3,
        }
    }
}

fn check_range(at: &str, key: &str, r: Range, min: f64, max: f64) -> Result<(), BehaviourError> {
    if !(r[0].is_finite() && r[1].is_finite() && r[0] <= r[1]) {
        return Err(BehaviourError::Spec(format!(
            "{at}: {key} = [{}, {}] must be [low, high] with low <= high",
            r[0], r[1]
        )));
    }
    if r[0] < min || r[1] > max {
        return Err(BehaviourError::Spec(format!(
            "{at}: {key} = [{}, {}] must lie within [{min}, {max}]",
            r[0], r[1]
        )));
    }
    Ok(())
}

fn check_prob(at: &str, key: &str, p: f64) -> Result<(), BehaviourError> {
    if !(0.0..=1.0).contains(&p) {
        return Err(BehaviourError::Spec(format!(
            "{at}: {key} = {p} must be a probability in [0, 1]"
        )));
    }
    Ok(())
}

impl GeneratorSpec {
    /// A generator of `model` with every range at its default.
    pub fn new(model: Model) -> Self {
        GeneratorSpec {
            model,
            people: None,
            duration_s: None,
            text: None,
            surfaces: None,
            layout: None,
            reader: None,
            talker: None,
            eye: None,
            interview: None,
        }
    }

    /// Rejects ranges that cannot be drawn from and tables that do not
    /// apply to the model; `at` names the table in messages (one line,
    /// as [`BehaviourError::Spec`]).
    pub fn validate(&self, at: &str) -> Result<(), BehaviourError> {
        let reads = matches!(self.model, Model::Reading | Model::Interview);
        let talks = matches!(self.model, Model::Conversation | Model::Interview);
        let m = self.model.name();
        let not_for = |key: &str| {
            Err(BehaviourError::Spec(format!(
                "{at}: '{key}' does not apply to model = \"{m}\""
            )))
        };
        if !reads {
            if self.text.is_some() {
                return not_for("text");
            }
            if self.surfaces.is_some() {
                return not_for("surfaces");
            }
            if self.layout.is_some() {
                return not_for("layout");
            }
            if self.reader.is_some() {
                return not_for("reader");
            }
        }
        if !talks && self.talker.is_some() {
            return not_for("talker");
        }
        if self.model != Model::Interview && self.interview.is_some() {
            return not_for("interview");
        }
        if self.people == Some(0) {
            return Err(BehaviourError::Spec(format!(
                "{at}: people must be at least 1"
            )));
        }
        if let Some(d) = self.duration_s {
            // At least a second (the pipeline needs frames to resample), at
            // most an hour (500 Hz samples are held in memory per person).
            if !(d.is_finite() && (1.0..=3600.0).contains(&d)) {
                return Err(BehaviourError::Spec(format!(
                    "{at}: duration_s = {d} must be in [1, 3600]"
                )));
            }
        }
        if self.surfaces.as_ref().is_some_and(|s| s.is_empty()) {
            return Err(BehaviourError::Spec(format!("{at}: surfaces is empty")));
        }
        if let Some(l) = &self.layout {
            for (k, r, lo, hi) in [
                ("layout.distance_mm", l.distance_mm, 100.0, 5000.0),
                ("layout.offset_x_mm", l.offset_x_mm, -3000.0, 3000.0),
                ("layout.offset_y_mm", l.offset_y_mm, -3000.0, 3000.0),
                ("layout.char_width_mm", l.char_width_mm, 0.2, 100.0),
                ("layout.line_chars", l.line_chars, 5.0, 400.0),
                ("layout.lines_per_page", l.lines_per_page, 1.0, 200.0),
            ] {
                if let Some(r) = r {
                    check_range(at, k, r, lo, hi)?;
                }
            }
        }
        let r = self.reader.clone().unwrap_or_default();
        check_prob(at, "reader.aloud_prob", r.aloud_prob)?;
        for (k, v, lo, hi) in [
            ("reader.fixation_mean_ms", r.fixation_mean_ms, 80.0, 1000.0),
            ("reader.fixation_shape", r.fixation_shape, 1.0, 100.0),
            ("reader.regression_prob", r.regression_prob, 0.0, 0.9),
            (
                "reader.refixation_per_char",
                r.refixation_per_char,
                0.0,
                1.0,
            ),
            ("reader.skip_scale", r.skip_scale, 0.0, 5.0),
            ("reader.corrective_prob", r.corrective_prob, 0.0, 1.0),
            ("reader.undersweep_ms", r.undersweep_ms, 50.0, 1000.0),
            ("reader.blinks_per_min", r.blinks_per_min, 0.0, 120.0),
        ] {
            check_range(at, k, v, lo, hi)?;
        }
        let t = self.talker.clone().unwrap_or_default();
        for (k, v, lo, hi) in [
            ("talker.partner_below_deg", t.partner_below_deg, -40.0, 40.0),
            ("talker.partner_side_deg", t.partner_side_deg, -40.0, 40.0),
            (
                "talker.face_share_listening",
                t.face_share_listening,
                0.01,
                1.0,
            ),
            (
                "talker.face_share_speaking",
                t.face_share_speaking,
                0.01,
                1.0,
            ),
            (
                "talker.face_dwell_listening_s",
                t.face_dwell_listening_s,
                0.1,
                60.0,
            ),
            (
                "talker.face_dwell_speaking_s",
                t.face_dwell_speaking_s,
                0.1,
                60.0,
            ),
            ("talker.speaking_turn_s", t.speaking_turn_s, 1.0, 600.0),
            ("talker.listening_turn_s", t.listening_turn_s, 1.0, 600.0),
            ("talker.aversion_deg", t.aversion_deg, 0.5, 40.0),
            (
                "talker.cognitive_aversion_prob",
                t.cognitive_aversion_prob,
                0.0,
                1.0,
            ),
            ("talker.face_scan_s", t.face_scan_s, 0.1, 10.0),
            ("talker.nods_per_s", t.nods_per_s, 0.0, 5.0),
            ("talker.nod_deg", t.nod_deg, 0.0, 15.0),
            ("talker.head_sway_deg", t.head_sway_deg, 0.0, 15.0),
            ("talker.eye_preference", t.eye_preference, 0.0, 1.0),
            ("talker.blinks_per_min", t.blinks_per_min, 0.0, 120.0),
        ] {
            check_range(at, k, v, lo, hi)?;
        }
        let y = self.eye.clone().unwrap_or_default();
        for (k, v, lo, hi) in [
            ("eye.eta_deg_per_s", y.eta_deg_per_s, 100.0, 1500.0),
            ("eye.c_deg", y.c_deg, 0.5, 50.0),
            ("eye.drift_deg2_per_s", y.drift_deg2_per_s, 0.0, 1.0),
            ("eye.microsaccade_hz", y.microsaccade_hz, 0.0, 10.0),
            ("eye.microsaccade_deg", y.microsaccade_deg, 0.0, 3.0),
            ("eye.posture_deg", y.posture_deg, 0.0, 15.0),
        ] {
            check_range(at, k, v, lo, hi)?;
        }
        let i = self.interview.clone().unwrap_or_default();
        check_range(at, "interview.talk_s", i.talk_s, 1.0, 3600.0)?;
        check_range(at, "interview.read_s", i.read_s, 1.0, 3600.0)?;
        check_range(at, "interview.glance_prob", i.glance_prob, 0.0, 1.0)?;
        check_prob(at, "interview.start_reading_prob", i.start_reading_prob)?;
        Ok(())
    }
}
