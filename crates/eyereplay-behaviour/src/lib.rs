//! Behaviour models: reading, conversation and interview gaze generated
//! from published models of eye movements, not replayed from recordings.
//!
//! ```text
//! GeneratorSpec (config ranges) --draw per person (seeded)--> Person
//!   Person --model--> Plan (shifts, blinks, nods, reading stretches)
//!   Plan --main sequence, drift, microsaccades, eye model--> samples of n at 500 Hz
//! ```
//!
//! The samples are normalized iris positions `n`, the coordinate every
//! other source of the pipeline gives, with blink flags and a per-sample
//! reading label; the pipeline calibrates, resamples and slices them like
//! an eye-tracker recording. docs/BEHAVIOUR.md lists every parameter with
//! its source and what the models leave out.

pub mod conversation;
pub mod geometry;
pub mod reading;
pub mod saccade;
pub mod spec;
pub mod text;
pub mod timeline;

pub use conversation::{ConversationStats, Talker, TalkerParams};
pub use geometry::{Angles, Gains, Surface, TextPlane};
pub use reading::{Reader, ReaderParams, ReadingStats};
pub use saccade::MainSequence;
pub use spec::{EyeRanges, GeneratorSpec, InterviewRanges, Model, ReaderRanges, TalkerRanges};
pub use timeline::{Fixational, Plan, PlanSample, SAMPLE_RATE_HZ};

use eyereplay_core::splitmix64;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Errors of the behaviour models.
#[derive(Debug, thiserror::Error)]
pub enum BehaviourError {
    #[error("{path}: {message}")]
    Text { path: PathBuf, message: String },
    #[error("{0}")]
    Spec(String),
}

/// A text to read: the bundled one, or a user's file (read once).
#[derive(Clone, Debug)]
pub struct ReadingText {
    pub name: String,
    pub text: String,
}

impl ReadingText {
    pub fn bundled() -> Self {
        ReadingText {
            name: "bundled".into(),
            text: text::BUNDLED_TEXT.to_string(),
        }
    }

    /// Reads a UTF-8 text file; fails with the path when it cannot, or when
    /// it holds fewer than 20 words (too few lines to read).
    pub fn from_file(path: &Path) -> Result<Self, BehaviourError> {
        let bad = |m: String| BehaviourError::Text {
            path: path.to_path_buf(),
            message: m,
        };
        let bytes = std::fs::read(path).map_err(|e| bad(format!("cannot read: {e}")))?;
        let text = String::from_utf8(bytes).map_err(|_| bad("not UTF-8 text".into()))?;
        let words = text.split_whitespace().count();
        if words < 20 {
            return Err(bad(format!(
                "{words} words: a text to read needs at least 20"
            )));
        }
        Ok(ReadingText {
            name: path
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default(),
            text,
        })
    }
}

/// One synthetic person: every parameter drawn for them.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Person {
    pub model: Model,
    pub seed: u64,
    pub duration_s: f64,
    pub main_sequence: MainSequence,
    pub fixational: Fixational,
    /// Slow postural drift the eyes counter-rotate, deg.
    pub posture_deg: f64,
    /// Time constant of the head following a gaze shift, s.
    pub head_tau_s: f64,
    pub blinks_per_min: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reader: Option<ReaderParams>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub plane: Option<TextPlane>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub text: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub talker: Option<TalkerParams>,
    /// Interview: talk and read stretch lengths, `[low, high]` s.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub talk_s: Option<[f64; 2]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub read_s: Option<[f64; 2]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub starts_reading: Option<bool>,
}

/// What one person's recording did, for the metadata.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Outcome {
    pub reading_s: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reading: Option<ReadingSummary>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub conversation: Option<ConversationStats>,
    pub blinks: usize,
}

/// A reader's emergent statistics.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ReadingSummary {
    pub words_per_min: f64,
    pub mean_fixation_ms: f64,
    #[serde(flatten)]
    pub counts: ReadingStats,
}

/// A generated recording.
#[derive(Clone, Debug)]
pub struct Generated {
    pub person: Person,
    pub outcome: Outcome,
    pub samples: Vec<PlanSample>,
    /// `[start, end)` s of each reading stretch.
    pub reading_spans: Vec<[f64; 2]>,
}

/// Shortest interval between two saccade onsets, s.
pub const REFRACTORY_S: f64 = 0.1;

/// The seed of person `person` of generator `generator` in class `class`
/// under the dataset seed.
pub fn person_seed(dataset_seed: u64, class: u64, generator: u64, person: u64) -> u64 {
    splitmix64(splitmix64(splitmix64(splitmix64(dataset_seed) ^ class) ^ generator) ^ person)
}

fn draw(r: [f64; 2], rng: &mut ChaCha8Rng) -> f64 {
    if r[1] > r[0] {
        r[0] + (r[1] - r[0]) * rng.gen::<f64>()
    } else {
        r[0]
    }
}

/// Draws a person's parameters from a generator's ranges.
pub fn draw_person(spec: &GeneratorSpec, seed: u64, duration_s: f64, text_name: &str) -> Person {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let eye = spec.eye.clone().unwrap_or_default();
    let main_sequence = MainSequence {
        eta_deg_per_s: draw(eye.eta_deg_per_s, &mut rng),
        c_deg: draw(eye.c_deg, &mut rng),
    };
    let fixational = Fixational {
        drift_deg2_per_s: draw(eye.drift_deg2_per_s, &mut rng),
        microsaccade_hz: draw(eye.microsaccade_hz, &mut rng),
        microsaccade_deg: draw(eye.microsaccade_deg, &mut rng),
    };
    let posture_deg = draw(eye.posture_deg, &mut rng);
    // Head movements of 10-40 deg take 200-600 ms (Freedman & Sparks
    // 1997): an exponential approach with a 0.12-0.3 s time constant.
    let head_tau_s = draw([0.12, 0.3], &mut rng);
    let reads = matches!(spec.model, Model::Reading | Model::Interview);
    let talks = matches!(spec.model, Model::Conversation | Model::Interview);
    let iv = spec.interview.clone().unwrap_or_default();
    let (reader, plane, reading_blinks) = if reads {
        let r = spec.reader.clone().unwrap_or_default();
        let params = ReaderParams {
            // Interview answers are spoken: a read answer is read aloud.
            aloud: spec.model == Model::Interview || rng.gen::<f64>() < r.aloud_prob,
            fixation_mean_ms: draw(r.fixation_mean_ms, &mut rng),
            fixation_shape: draw(r.fixation_shape, &mut rng),
            regression_prob: draw(r.regression_prob, &mut rng),
            refixation_per_char: draw(r.refixation_per_char, &mut rng),
            skip_scale: draw(r.skip_scale, &mut rng),
            corrective_prob: draw(r.corrective_prob, &mut rng),
            undersweep_ms: draw(r.undersweep_ms, &mut rng),
            glance_prob: if spec.model == Model::Interview {
                draw(iv.glance_prob, &mut rng)
            } else {
                0.0
            },
        };
        let surfaces = spec
            .surfaces
            .clone()
            .unwrap_or_else(|| Surface::ALL.to_vec());
        let surface = surfaces[rng.gen_range(0..surfaces.len())];
        let pre = surface.preset();
        let l = spec.layout.clone().unwrap_or_default();
        let mut x = draw(l.offset_x_mm.unwrap_or(pre.offset_x_mm), &mut rng);
        if surface == Surface::MonitorSide && rng.gen::<bool>() {
            x = -x;
        }
        let char_w = draw(l.char_width_mm.unwrap_or(pre.char_width_mm), &mut rng);
        let plane = TextPlane {
            surface,
            centre_mm: [
                x,
                draw(l.offset_y_mm.unwrap_or(pre.offset_y_mm), &mut rng),
                draw(l.distance_mm.unwrap_or(pre.distance_mm), &mut rng),
            ],
            char_width_mm: char_w,
            // Font height about twice the advance width, 1.2-1.5 leading.
            line_pitch_mm: char_w * 2.0 * (1.2 + 0.3 * rng.gen::<f64>()),
            line_chars: draw(l.line_chars.unwrap_or(pre.line_chars), &mut rng).round() as usize,
            lines_per_page: draw(l.lines_per_page.unwrap_or(pre.lines_per_page), &mut rng)
                .round()
                .max(1.0) as usize,
            scroll: pre.scroll,
        };
        (Some(params), Some(plane), draw(r.blinks_per_min, &mut rng))
    } else {
        (None, None, 0.0)
    };
    let (talker, talk_blinks) = if talks {
        let t = spec.talker.clone().unwrap_or_default();
        let params = TalkerParams {
            partner: Angles::new(
                draw(t.partner_side_deg, &mut rng),
                -draw(t.partner_below_deg, &mut rng),
            ),
            face_share_listening: draw(t.face_share_listening, &mut rng),
            face_share_speaking: draw(t.face_share_speaking, &mut rng),
            face_dwell_listening_s: draw(t.face_dwell_listening_s, &mut rng),
            face_dwell_speaking_s: draw(t.face_dwell_speaking_s, &mut rng),
            speaking_turn_s: draw(t.speaking_turn_s, &mut rng),
            listening_turn_s: draw(t.listening_turn_s, &mut rng),
            aversion_deg: draw(t.aversion_deg, &mut rng),
            cognitive_aversion_prob: draw(t.cognitive_aversion_prob, &mut rng),
            face_scan_s: draw(t.face_scan_s, &mut rng),
            nods_per_s: draw(t.nods_per_s, &mut rng),
            nod_deg: draw(t.nod_deg, &mut rng),
            head_sway_deg: draw(t.head_sway_deg, &mut rng),
            eye_preference: draw(t.eye_preference, &mut rng),
        };
        (Some(params), draw(t.blinks_per_min, &mut rng))
    } else {
        (None, 0.0)
    };
    let blinks_per_min = match spec.model {
        Model::Reading => reading_blinks,
        Model::Conversation => talk_blinks,
        // One rate for the person: between their reading and talking rates.
        Model::Interview => 0.5 * (reading_blinks + talk_blinks),
    };
    let interview = spec.model == Model::Interview;
    Person {
        model: spec.model,
        seed,
        duration_s,
        main_sequence,
        fixational,
        posture_deg,
        head_tau_s,
        blinks_per_min,
        reader,
        plane,
        text: reads.then(|| text_name.to_string()),
        talker,
        talk_s: interview.then_some(iv.talk_s),
        read_s: interview.then_some(iv.read_s),
        starts_reading: interview.then(|| rng.gen::<f64>() < iv.start_reading_prob),
    }
}

/// Generates one person's recording: plans it with their model, then
/// synthesizes samples of `n` with `gains` (the dataset's eye model).
pub fn generate(person: &Person, text: &ReadingText, gains: &Gains) -> Generated {
    // A second stream for the plan, so that drawing parameters and planning
    // do not shift each other when a range changes.
    let mut rng = ChaCha8Rng::seed_from_u64(splitmix64(person.seed ^ 0x005E_ED0F_B1A5));
    let dur = person.duration_s;
    let mut plan = Plan::default();
    let mut outcome = Outcome::default();
    let layout = person.plane.map(|p| text::layout(&text.text, p.line_chars));
    let mut reader = match (&person.reader, &person.plane, &layout) {
        (Some(r), Some(p), Some(l)) => {
            let start_line = rng.gen_range(0..l.lines.max(1));
            Some(Reader::new(
                r.clone(),
                *p,
                l,
                person.main_sequence,
                start_line,
            ))
        }
        _ => None,
    };
    let talker = person.talker.clone().map(|params| Talker { params });
    let mut rstats = ReadingStats::default();
    let mut cstats = ConversationStats::default();
    match person.model {
        Model::Reading => {
            let r = reader.as_mut().expect("a reader");
            plan.start = r.eye_at(0, 0.0);
            rstats = r.read(&mut plan, 0.0, dur, &mut rng);
            plan.reading.push([0.0, dur]);
        }
        Model::Conversation => {
            let t = talker.as_ref().expect("a talker");
            plan.start = t.params.partner;
            plan.head_tau_s = person.head_tau_s;
            t.sway(&mut plan, &mut rng);
            cstats = t.converse(&mut plan, 0.0, dur, rng.gen::<bool>(), &mut rng);
        }
        Model::Interview => {
            let t = talker.as_ref().expect("a talker");
            let r = reader.as_mut().expect("a reader");
            plan.start = t.params.partner;
            plan.head_tau_s = person.head_tau_s;
            t.sway(&mut plan, &mut rng);
            let mut reading = person.starts_reading == Some(true);
            let ranges = InterviewRanges::default();
            let read_range = person.read_s.unwrap_or(ranges.read_s);
            let talk_range = person.talk_s.unwrap_or(ranges.talk_s);
            let mut at = 0.0;
            while at < dur {
                // An interview recording ends after an answer, not a
                // second into one: a read answer the end would cut below
                // the shortest answer is not started, and the candidate
                // talks to the end instead. (A session that opens reading
                // and is shorter than that still reads: there is nothing
                // else it could be labelled.)
                if reading && at > 0.0 && dur - at < read_range[0] {
                    reading = false;
                }
                let len = if reading {
                    draw(read_range, &mut rng)
                } else {
                    draw(talk_range, &mut rng)
                };
                let end = (at + len).min(dur);
                if reading {
                    rstats.add(&r.read(&mut plan, at, end, &mut rng));
                    plan.reading.push([at, end]);
                } else {
                    // A question heard, then the answer given: one
                    // listening turn and one speaking turn.
                    let q = (at + 1.5 + 3.0 * rng.gen::<f64>()).min(end);
                    t.turn(&mut plan, at, q, false, &mut cstats, &mut rng);
                    if q < end {
                        t.turn(&mut plan, q, end, true, &mut cstats, &mut rng);
                    }
                }
                at = end;
                reading = !reading;
            }
        }
    }
    plan.blinks = timeline::poisson_blinks(person.blinks_per_min, dur, &mut rng);
    // Posture: the head drifts slowly (two sinusoids an axis at 0.02-0.1
    // Hz) while the eyes hold their targets, so the eye in the head drifts
    // against it, as real webcam talkers' iris tracks do over seconds.
    for yaw in [true, false] {
        for _ in 0..2 {
            plan.sway.push(timeline::Sway {
                amp_deg: person.posture_deg / 2.0 * (0.5 + rng.gen::<f64>()),
                freq_hz: 0.02 + 0.08 * rng.gen::<f64>(),
                phase: std::f64::consts::TAU * rng.gen::<f64>(),
                yaw,
            });
        }
    }
    // Shifts must be in time order for the synthesis; models append in
    // order except where an aversion starts before its turn.
    plan.shifts
        .sort_by(|a, b| a.t_s.partial_cmp(&b.t_s).expect("finite shift times"));
    // The saccadic refractory period: no saccade starts within 0.1 s of
    // the one before; a later target replaces the earlier one.
    let mut kept: Vec<timeline::Shift> = Vec::with_capacity(plan.shifts.len());
    for s in plan.shifts.drain(..) {
        match kept.last_mut() {
            Some(last) if s.t_s - last.t_s < REFRACTORY_S => last.to = s.to,
            _ => kept.push(s),
        }
    }
    plan.shifts = kept;
    plan.head
        .sort_by(|a, b| a.t_s.partial_cmp(&b.t_s).expect("finite head times"));
    plan.nods
        .sort_by(|a, b| a.t_s.partial_cmp(&b.t_s).expect("finite nod times"));
    let samples = plan.synthesize(
        dur,
        &person.main_sequence,
        &person.fixational,
        gains,
        &mut rng,
    );
    outcome.reading_s = plan.reading.iter().map(|r| r[1] - r[0]).sum();
    outcome.blinks = plan.blinks.len();
    if reader.is_some() {
        outcome.reading = Some(ReadingSummary {
            words_per_min: rstats.words_per_min(),
            mean_fixation_ms: rstats.mean_fixation_ms(),
            counts: rstats,
        });
    }
    if talker.is_some() {
        outcome.conversation = Some(cstats);
    }
    Generated {
        person: person.clone(),
        outcome,
        samples,
        reading_spans: plan.reading,
    }
}
