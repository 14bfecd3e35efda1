//! When does someone read? The localization protocol (`eyereplay
//! evaluate-localization`): on sessions whose per-frame `reading` column
//! is known (behaviour models' interview scenarios), each way of turning
//! window scores into frames ([`eyereplay_detect::localize::Method`]) finds
//! reading segments, and they are matched to the true ones: segment F1 at
//! IoU 0.5, onset error, and the share of not-reading time called reading.

use eyereplay::detector::window_label;
use eyereplay::detector::{dataset_sessions, session_tracks, TrainInput};
use eyereplay::{Error, Result};
use eyereplay_core::Progress;
use eyereplay_detect::calibration::{expected_calibration_error, reliability, ReliabilityBin};
use eyereplay_detect::clip::score_clip;
use eyereplay_detect::localize::{self, matched_pairs, Method, SegmentMatch};
use eyereplay_detect::metrics::{auroc, rate_at};
use eyereplay_detect::{
    features, windows, DetectorModel, Track, WindowSpec, FEATURE_COUNT, FEATURE_NAMES, FPS,
};
use serde::Serialize;
use std::path::Path;

/// Segments of at least this IoU with a true one count as found.
pub const MIN_IOU: f64 = 0.5;

/// One method's results over every session.
#[derive(Clone, Debug, Serialize)]
pub struct MethodResult {
    pub method: Method,
    /// Pooled over sessions (each session matched on its own).
    pub segments: SegmentMatch,
    pub onset_error_median_s: Option<f64>,
    /// Signed, over the matched pairs: the median of found start minus
    /// true start, leaving out stretches that start with their session
    /// (positive: the segments start late), and of found end minus true
    /// end, leaving out those that end with it (negative: they end early).
    pub start_offset_median_s: Option<f64>,
    pub end_offset_median_s: Option<f64>,
    /// Frames called reading among the frames that are not reading.
    pub false_reading_fraction: f64,
    /// Frames called reading among the frames that are reading.
    pub reading_recall: f64,
}

/// Whether the model's window probabilities mean what they say on these
/// sessions: non-overlapping windows of the model's length, each labelled
/// by its frames (reading when 80 % read, not when 20 % or fewer, left out
/// in between).
#[derive(Clone, Debug, Serialize)]
pub struct WindowCalibration {
    pub windows_reading: usize,
    pub windows_other: usize,
    /// 10 equal bins of predicted probability.
    pub reliability: Vec<ReliabilityBin>,
    pub expected_calibration_error: f64,
    /// The model's decision threshold, and what it does here.
    pub threshold: f64,
    pub false_positive_rate: f64,
    pub true_positive_rate: f64,
    /// The false-positive rate the threshold was chosen for (on the
    /// training data's validation sessions).
    pub target_false_positive_rate: f64,
    /// How well the windows' probabilities separate the classes, pooled
    /// over every recording; `None` without both classes.
    pub auroc: Option<f64>,
    /// The same within each recording, averaged over the recordings that
    /// have windows of both classes: what a detector that knew each
    /// person's own level could reach at best by ranking.
    pub auroc_within_recording: Option<f64>,
    pub recordings_with_both: usize,
}

/// The labelled windows of `tracks`: non-overlapping windows of the
/// model's length, each with its probability, its label from the per-frame
/// `flags` (windows that straddle a switch left out), its track's index
/// and its features (what the model scored it from).
#[derive(Clone, Debug, Default)]
pub struct LabelledWindows {
    pub probability: Vec<f64>,
    pub reading: Vec<bool>,
    pub track: Vec<usize>,
    pub features: Vec<[f64; FEATURE_COUNT]>,
}

/// One feature alone as a score: how well it separates some reading
/// windows from the windows that are not reading.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FeatureAuroc {
    /// As [`FEATURE_NAMES`] names it.
    pub feature: String,
    /// 0.5 separates nothing; under 0.5 the reading windows score lower
    /// (a skewness that return sweeps make negative). `None` without
    /// windows of both kinds.
    pub auroc: Option<f64>,
}

impl LabelledWindows {
    pub fn of(tracks: &[Track], flags: &[Vec<bool>], model: &DetectorModel) -> Self {
        let spec = WindowSpec::seconds(model.window_s);
        let mut out = LabelledWindows::default();
        for (r, (t, f)) in tracks.iter().zip(flags).enumerate() {
            for w in windows(t, spec) {
                if let Some(label) = window_label(f, w.start, spec.frames) {
                    let values = features(&w);
                    out.probability.push(model.probability_of(&values));
                    out.reading.push(label);
                    out.track.push(r);
                    out.features.push(values);
                }
            }
        }
        out
    }

    /// Pooled AUROC of the windows of the tracks `keep` picks.
    pub fn auroc_of(&self, keep: impl Fn(usize) -> bool) -> Option<f64> {
        let (p, l): (Vec<f64>, Vec<bool>) = (0..self.probability.len())
            .filter(|&i| keep(self.track[i]))
            .map(|i| (self.probability[i], self.reading[i]))
            .unzip();
        auroc(&p, &l)
    }

    /// Each feature alone: the AUROC of the reading windows of the tracks
    /// `keep` picks against every window that is not reading, of every
    /// track. Every track's talk, not only the picked ones': a kind of
    /// reading a few sessions hold is set against all the talk a model
    /// must tell it from.
    pub fn feature_aurocs(&self, keep: impl Fn(usize) -> bool) -> Vec<FeatureAuroc> {
        let picked: Vec<usize> = (0..self.reading.len())
            .filter(|&i| !self.reading[i] || keep(self.track[i]))
            .collect();
        let labels: Vec<bool> = picked.iter().map(|&i| self.reading[i]).collect();
        FEATURE_NAMES
            .iter()
            .enumerate()
            .map(|(k, name)| {
                let values: Vec<f64> = picked.iter().map(|&i| self.features[i][k]).collect();
                FeatureAuroc {
                    feature: name.to_string(),
                    auroc: auroc(&values, &labels),
                }
            })
            .collect()
    }

    /// The pooled AUROC, and the mean AUROC within each track over the
    /// tracks with windows of both classes, with their count.
    pub fn aurocs(&self) -> (Option<f64>, Option<f64>, usize) {
        let mut ids = self.track.clone();
        ids.sort_unstable();
        ids.dedup();
        let within: Vec<f64> = ids
            .into_iter()
            .filter_map(|r| self.auroc_of(|t| t == r))
            .collect();
        let mean = (!within.is_empty()).then(|| within.iter().sum::<f64>() / within.len() as f64);
        (self.auroc_of(|_| true), mean, within.len())
    }
}

/// [`WindowCalibration`] of `model` on `tracks` with per-frame `flags`.
pub fn window_calibration(
    tracks: &[Track],
    flags: &[Vec<bool>],
    model: &DetectorModel,
) -> WindowCalibration {
    calibration_of(&LabelledWindows::of(tracks, flags, model), model)
}

fn calibration_of(w: &LabelledWindows, model: &DetectorModel) -> WindowCalibration {
    let (p, l) = (w.probability.as_slice(), w.reading.as_slice());
    let (auroc, auroc_within_recording, recordings_with_both) = w.aurocs();
    let reliability = reliability(p, l, 10);
    let of = |c: bool| -> Vec<f64> {
        p.iter()
            .zip(l)
            .filter(|(_, &x)| x == c)
            .map(|(&v, _)| v)
            .collect()
    };
    let (neg, pos) = (of(false), of(true));
    WindowCalibration {
        windows_reading: pos.len(),
        windows_other: neg.len(),
        expected_calibration_error: expected_calibration_error(&reliability),
        reliability,
        threshold: model.threshold,
        false_positive_rate: rate_at(&neg, model.threshold),
        true_positive_rate: rate_at(&pos, model.threshold),
        target_false_positive_rate: model.training.options.max_fpr,
        auroc,
        auroc_within_recording,
        recordings_with_both,
    }
}

/// Clips of one length cut from the sessions, each inside one class.
#[derive(Clone, Debug, Serialize)]
pub struct ClipResult {
    pub clip_s: f64,
    pub clips_reading: usize,
    pub clips_other: usize,
    /// Clips refused for too little gaze.
    pub refused: usize,
    pub auroc: Option<f64>,
    /// Share of the scored clips whose interval holds the threshold.
    pub uncertain_fraction: f64,
    /// Share right among the scored clips with a verdict.
    pub decided_accuracy: Option<f64>,
    /// Mean width of the interval.
    pub mean_interval_width: f64,
}

/// Clips of each length and class [`evaluate_localization`] scores.
pub const CLIPS_PER_CLASS: usize = 60;

/// Lengths of the short clips [`clip_results`] scores.
pub const CLIP_LENGTHS_S: [f64; 3] = [3.0, 5.0, 8.0];

/// Short clips scored as `eyereplay detect` scores a clip shorter than
/// one window ([`eyereplay_detect::clip`]): up to `per_class` clips of
/// each length and class, at places drawn with `seed`, each wholly
/// inside reading or wholly outside it.
pub fn clip_results(
    tracks: &[Track],
    flags: &[Vec<bool>],
    model: &DetectorModel,
    per_class: usize,
    seed: u64,
) -> Vec<ClipResult> {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    CLIP_LENGTHS_S
        .iter()
        .map(|&clip_s| {
            let n = (clip_s * FPS).round() as usize;
            // Every start whose clip lies inside one class, per class.
            let mut starts: [Vec<(usize, usize)>; 2] = [Vec::new(), Vec::new()];
            for (ti, f) in flags.iter().enumerate() {
                for (a, b) in localize::runs(f.iter().copied()) {
                    starts[1].extend((a..b.saturating_sub(n - 1)).step_by(n).map(|s| (ti, s)));
                }
                for (a, b) in localize::runs(f.iter().map(|&r| !r)) {
                    starts[0].extend((a..b.saturating_sub(n - 1)).step_by(n).map(|s| (ti, s)));
                }
            }
            let (mut p, mut l, mut widths) = (Vec::new(), Vec::new(), Vec::new());
            let (mut refused, mut uncertain, mut right, mut decided) = (0, 0, 0, 0);
            let mut counts = [0usize; 2];
            for (class, list) in starts.iter_mut().enumerate() {
                // A seeded partial shuffle picks the clips.
                let take = per_class.min(list.len());
                for i in 0..take {
                    let j = rng.gen_range(i..list.len());
                    list.swap(i, j);
                }
                for &(ti, s) in &list[..take] {
                    let clip = Track::new(tracks[ti].xy[s..s + n].to_vec());
                    counts[class] += 1;
                    let Ok(c) = score_clip(&clip, model) else {
                        refused += 1;
                        continue;
                    };
                    p.push(c.reading_probability);
                    l.push(class == 1);
                    widths.push(c.high - c.low);
                    if c.low < model.threshold && c.high >= model.threshold {
                        uncertain += 1;
                    } else {
                        decided += 1;
                        right += usize::from((c.low >= model.threshold) == (class == 1));
                    }
                }
            }
            let scored = p.len().max(1) as f64;
            ClipResult {
                clip_s,
                clips_reading: counts[1],
                clips_other: counts[0],
                refused,
                auroc: eyereplay_detect::auroc(&p, &l),
                uncertain_fraction: uncertain as f64 / scored,
                decided_accuracy: (decided > 0).then(|| right as f64 / decided as f64),
                mean_interval_width: widths.iter().sum::<f64>() / scored,
            }
        })
        .collect()
}

/// What [`evaluate_localization`] measured.
#[derive(Clone, Debug, Serialize)]
pub struct LocalizationEval {
    pub dataset: String,
    /// `trajectory` or `extracted` (read back from the rendered videos).
    pub input: String,
    pub model: String,
    /// Where segments are cut.
    pub threshold: f64,
    pub sessions: usize,
    pub reading_segments: usize,
    pub seconds: f64,
    pub methods: Vec<MethodResult>,
    pub calibration: WindowCalibration,
    pub clips: Vec<ClipResult>,
    /// `detect`'s method ([`localize::DEFAULT_METHOD`]) per reading
    /// surface, for sessions the interview model made (metadata.json names
    /// where each person reads from); empty when it names none.
    pub by_surface: Vec<SurfaceResult>,
    /// Each feature alone on every reading window against every talk
    /// window ([`LabelledWindows::feature_aurocs`]).
    pub feature_auroc: Vec<FeatureAuroc>,
    /// Every read answer scored (each session's [`true_segments`]) and what
    /// `detect`'s method made of it, session by session.
    pub answers: Vec<AnswerResult>,
}

/// One true read answer and what `detect`'s method
/// ([`localize::DEFAULT_METHOD`]) made of it: found or not, and the
/// circumstances a miss is read against.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct AnswerResult {
    /// The session as labels.csv names it (`conversation/conversation_0003.csv`).
    pub session: String,
    /// Where its person reads from (metadata.json), when the behaviour
    /// model says.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub surface: Option<String>,
    pub start_s: f64,
    pub end_s: f64,
    /// Matched one-to-one by a found segment at IoU >= 0.5: what segment
    /// F1 counts.
    pub found: bool,
    /// The largest IoU of any found segment with it (0 when none overlaps).
    pub best_iou: f64,
    /// That best segment also overlaps another read answer: two answers
    /// joined into one segment across the talk between them.
    pub joined: bool,
    /// It runs to the session's last frame: the recording cut it.
    pub at_session_end: bool,
    /// How its video was matched to the extractor, from the session's
    /// identity file; absent where not read back from video or no
    /// identity file says.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub extractor_match: Option<ExtractorMatched>,
}

/// How a session's video was matched to the extractor (its
/// `_identity.json`): `both` axes, `horizontal` or `vertical` only (the
/// other drawn at the geometric position), or `none`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ExtractorMatched {
    Both,
    Horizontal,
    Vertical,
    None,
}

impl ExtractorMatched {
    /// What a reader of a missed answer should know, where it is worth
    /// saying.
    pub fn caveat(self) -> Option<&'static str> {
        match self {
            ExtractorMatched::Both => Option::None,
            ExtractorMatched::Horizontal => Some("matched to the extractor horizontally only"),
            ExtractorMatched::Vertical => Some("matched to the extractor vertically only"),
            ExtractorMatched::None => Some("drawn without the extractor match"),
        }
    }
}

/// Each of `truth`'s answers against the `found` segments of one session
/// of `duration_s`, matched one-to-one as `pairs` say ([`matched_pairs`]),
/// as [`AnswerResult`]s (`session`, `surface` and `extractor_match`
/// copied into each).
pub fn answer_results(
    session: &str,
    surface: Option<&str>,
    truth: &[(f64, f64)],
    found: &[(f64, f64)],
    pairs: &[(usize, usize)],
    duration_s: f64,
    extractor_match: Option<ExtractorMatched>,
) -> Vec<AnswerResult> {
    truth
        .iter()
        .enumerate()
        .map(|(j, &t)| {
            let best = found
                .iter()
                .map(|&f| (localize::iou(f, t), f))
                .filter(|(v, _)| *v > 0.0)
                .max_by(|a, b| a.0.total_cmp(&b.0));
            let overlaps = |a: (f64, f64), b: (f64, f64)| a.0.max(b.0) < a.1.min(b.1);
            let joined = best.is_some_and(|(_, f)| {
                truth
                    .iter()
                    .enumerate()
                    .any(|(k, &other)| k != j && overlaps(f, other))
            });
            AnswerResult {
                session: session.to_string(),
                surface: surface.map(str::to_string),
                start_s: t.0,
                end_s: t.1,
                found: pairs.iter().any(|&(_, m)| m == j),
                best_iou: best.map_or(0.0, |(v, _)| v),
                joined,
                at_session_end: ends_session(t.1, duration_s),
                extractor_match,
            }
        })
        .collect()
}

/// How the session whose identity file is `path` was matched to the
/// extractor; `None` when there is no such file. One that cannot be read
/// is an error naming it.
pub fn extractor_matched(path: &Path) -> Result<Option<ExtractorMatched>> {
    if !path.exists() {
        return Ok(Option::None);
    }
    let identity = eyereplay_dataset::SessionIdentity::read(path)?;
    let matched = identity
        .mapping
        .get("extractor_response")
        .is_some_and(|r| !r.is_null());
    // The face mode names the axis it left geometric, where it matched one.
    Ok(Some(
        match (matched, identity.identity["geometric_axis"].as_str()) {
            (false, _) => ExtractorMatched::None,
            (true, Some("vertical")) => ExtractorMatched::Horizontal,
            (true, Some("horizontal")) => ExtractorMatched::Vertical,
            (true, _) => ExtractorMatched::Both,
        },
    ))
}

/// One reading surface's sessions (a teleprompter, a laptop, ...), scored
/// by `detect`'s method: how readable each kind of reading is once drawn.
#[derive(Clone, Debug, Serialize)]
pub struct SurfaceResult {
    pub surface: String,
    pub sessions: usize,
    /// Median visual angle of one line of text across these sessions'
    /// people: what a return sweep spans (forward saccades are about a
    /// tenth of it).
    pub line_span_deg: f64,
    pub result: MethodResult,
    /// How well these sessions' windows separate (pooled AUROC of the
    /// labelled windows, as [`WindowCalibration::auroc`]); `None` without
    /// both classes.
    pub window_auroc: Option<f64>,
    /// Each feature alone on these sessions' reading windows against the
    /// talk windows of every session ([`LabelledWindows::feature_aurocs`]):
    /// what is left of this kind of reading once drawn and read back.
    pub feature_auroc: Vec<FeatureAuroc>,
}

/// Where a behaviour-model source reads from.
#[derive(Clone, Debug, PartialEq)]
pub struct SourceSurface {
    pub surface: String,
    /// Visual angle of one whole line, deg.
    pub line_span_deg: f64,
}

/// Where each behaviour-model source of a dataset reads from: source id ->
/// surface, from `metadata.json` (`sources[].behaviour.params.plane`).
/// Sources without a text plane (a talker, a real recording) are absent;
/// a dataset without metadata gives an empty map.
pub fn source_surfaces(dir: &Path) -> Result<std::collections::BTreeMap<String, SourceSurface>> {
    let path = dir.join("metadata.json");
    let mut out = std::collections::BTreeMap::new();
    let Ok(text) = std::fs::read_to_string(&path) else {
        return Ok(out);
    };
    let meta: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| Error::input(&path, e.to_string()))?;
    for src in meta["sources"].as_array().into_iter().flatten() {
        let plane = &src["behaviour"]["params"]["plane"];
        let number = |k: &str| plane[k].as_f64();
        let centre: Option<Vec<f64>> = plane["centre_mm"]
            .as_array()
            .and_then(|c| c.iter().map(|v| v.as_f64()).collect());
        if let (Some(id), Some(surface), Some(chars), Some(width), Some(centre)) = (
            src["id"].as_str(),
            plane["surface"].as_str(),
            number("line_chars"),
            number("char_width_mm"),
            centre,
        ) {
            let distance_mm = centre.iter().map(|v| v * v).sum::<f64>().sqrt();
            // A line centred on the gaze: 2 atan(half its width / distance).
            let line_span_deg = 2.0 * (chars * width / 2.0 / distance_mm).atan().to_degrees();
            out.insert(
                id.to_string(),
                SourceSurface {
                    surface: surface.to_string(),
                    line_span_deg,
                },
            );
        }
    }
    Ok(out)
}

/// Runs of `true` in `flags`, as `(start_s, end_s)` at [`FPS`].
/// The read stretches a method is scored against: runs of `flags` of at
/// least [`localize::MIN_SEGMENT_S`] (a shorter one, an answer the
/// session's end cut to a few seconds, cannot be found by design).
pub fn true_segments(flags: &[bool]) -> Vec<(f64, f64)> {
    true_runs(flags)
        .into_iter()
        .filter(|(a, b)| b - a >= localize::MIN_SEGMENT_S)
        .collect()
}

pub fn true_runs(flags: &[bool]) -> Vec<(f64, f64)> {
    localize::runs(flags.iter().copied())
        .into_iter()
        .map(|(a, b)| (a as f64 / FPS, b as f64 / FPS))
        .collect()
}

const NO_READING_COLUMN: &str =
    "no session has a per-frame reading column (generate interview sessions: model = \"interview\")";

/// Every session of the dataset in `dir` that has a `reading` column, read
/// as `input` says (its trajectory, or read back from its video; short
/// clips cut at places drawn with `seed`), localized by each method with `detector`.
pub fn evaluate_localization(
    dir: &Path,
    detector: crate::NamedDetector<'_>,
    threshold: f64,
    input: TrainInput,
    seed: u64,
    cache: &Path,
    progress: &dyn Progress,
) -> Result<LocalizationEval> {
    let (model, model_path) = (detector.model, detector.name);
    let surfaces = source_surfaces(dir)?;
    let mut tracks = Vec::new();
    let mut flags_all = Vec::new();
    let mut session_surface = Vec::new();
    // Before any extraction: the sessions with per-frame labels (the ones
    // scored; the others are not read), long enough for one window.
    let mut sessions = dataset_sessions(&[dir.to_path_buf()], input)?;
    sessions.retain(|s| s.frame_reading.is_some());
    if sessions.is_empty() {
        return Err(Error::input(dir, NO_READING_COLUMN));
    }
    let longest_s = sessions.iter().map(|s| s.duration_s()).fold(0.0, f64::max);
    if longest_s < model.window_s {
        return Err(Error::input(
            model_path,
            format!(
                "its windows are {} s, longer than the longest session of {} ({longest_s:.1} s)",
                model.window_s,
                dir.display()
            ),
        ));
    }
    // Also before it: how each video was matched (an unreadable identity
    // file stops the run here, not after the extraction).
    let matched: Vec<Option<ExtractorMatched>> = sessions
        .iter()
        .map(|s| match input {
            TrainInput::Extracted => extractor_matched(
                &eyereplay_dataset::SessionPaths::beside_video(&s.file).identity_json,
            ),
            _ => Ok(Option::None),
        })
        .collect::<Result<_>>()?;
    let mut session_names = Vec::new();
    let mut session_matched = Vec::new();
    for (t, matched) in session_tracks(sessions, input, cache, progress)?
        .into_iter()
        .zip(matched)
    {
        let Some(mut flags) = t.frame_reading else {
            continue;
        };
        session_surface.push(t.sources.iter().find_map(|s| surfaces.get(s).cloned()));
        // `DATASET#conversation/conversation_0003.csv`: the part labels.csv names.
        let file = t.id.rsplit_once('#').map_or(t.id.as_str(), |(_, f)| f);
        session_names.push(file.to_string());
        session_matched.push(matched);
        // A video may end a frame short of its trajectory.
        flags.truncate(t.track.len());
        let mut track = t.track;
        track.xy.truncate(flags.len());
        tracks.push(track);
        flags_all.push(flags);
    }
    let scores_of = |m: Method| -> Vec<SessionScore> {
        tracks
            .iter()
            .zip(&flags_all)
            .map(|(t, f)| score_session(t, f, model, m, threshold))
            .collect()
    };
    let scored: Vec<(Method, Vec<SessionScore>)> =
        Method::ALL.into_iter().map(|m| (m, scores_of(m))).collect();
    let methods = scored.iter().map(|(m, s)| pool(*m, s)).collect();
    let detects = scored
        .iter()
        .find(|(m, _)| *m == localize::DEFAULT_METHOD)
        .map(|(_, s)| s.as_slice())
        .expect("Method::ALL holds the default");
    let labelled = LabelledWindows::of(&tracks, &flags_all, model);
    let calibration = calibration_of(&labelled, model);
    let clips = clip_results(&tracks, &flags_all, model, CLIPS_PER_CLASS, seed);
    let by_surface = by_surface(detects, &session_surface, &labelled);
    let feature_auroc = labelled.feature_aurocs(|_| true);
    let answers = detects
        .iter()
        .enumerate()
        .flat_map(|(i, score)| {
            answer_results(
                &session_names[i],
                session_surface[i].as_ref().map(|s| s.surface.as_str()),
                &true_segments(&flags_all[i]),
                &score.found_segments,
                &score.matched_pairs,
                flags_all[i].len() as f64 / FPS,
                session_matched[i],
            )
        })
        .collect();
    Ok(LocalizationEval {
        dataset: dir.display().to_string(),
        input: input.name().into(),
        model: model_path.display().to_string(),
        threshold,
        sessions: tracks.len(),
        reading_segments: flags_all.iter().map(|f| true_segments(f).len()).sum(),
        seconds: tracks.iter().map(|t| t.duration_s()).sum(),
        methods,
        calibration,
        clips,
        by_surface,
        feature_auroc,
        answers,
    })
}

/// Each surface's sessions pooled from their scores by `detect`'s method
/// ([`localize::DEFAULT_METHOD`]; `scores[i]` of session `i`), with their
/// windows' AUROC from `windows` (whose track `i` is session `i`), in name
/// order.
pub fn by_surface(
    scores: &[SessionScore],
    surfaces: &[Option<SourceSurface>],
    windows: &LabelledWindows,
) -> Vec<SurfaceResult> {
    let mut names: Vec<&String> = surfaces.iter().flatten().map(|s| &s.surface).collect();
    names.sort();
    names.dedup();
    names
        .into_iter()
        .map(|name| {
            let pick: Vec<&SourceSurface> = surfaces
                .iter()
                .flatten()
                .filter(|s| &s.surface == name)
                .collect();
            let spans: Vec<f64> = pick.iter().map(|s| s.line_span_deg).collect();
            let on = |i: usize| surfaces[i].as_ref().is_some_and(|s| &s.surface == name);
            let mine = scores
                .iter()
                .enumerate()
                .filter(|&(i, _)| on(i))
                .map(|(_, score)| score);
            SurfaceResult {
                surface: name.clone(),
                sessions: pick.len(),
                line_span_deg: eyereplay_signal::stats::median(&spans).unwrap_or(f64::NAN),
                result: pool(localize::DEFAULT_METHOD, mine),
                window_auroc: windows.auroc_of(on),
                feature_auroc: windows.feature_aurocs(on),
            }
        })
        .collect()
}

/// One session localized by one method, scored against the
/// [`true_segments`] of its per-frame labels.
#[derive(Clone, Debug, Default)]
pub struct SessionScore {
    pub segments_found: usize,
    pub segments_true: usize,
    pub onset_errors_s: Vec<f64>,
    /// Found start minus true start of each matched pair whose true
    /// stretch does not start the session; found end minus true end of
    /// each whose stretch does not end it (what a session's edge cuts says
    /// nothing of the segments' own edges).
    pub start_offsets_s: Vec<f64>,
    pub end_offsets_s: Vec<f64>,
    /// Frames not reading, and those of them called reading.
    pub other_frames: usize,
    pub false_frames: usize,
    /// Frames reading, and those of them called reading.
    pub reading_frames: usize,
    pub found_frames: usize,
    /// The segments found, `(start_s, end_s)`.
    pub found_segments: Vec<(f64, f64)>,
    /// `(found index, true index)` of each pair segment F1 counts
    /// ([`matched_pairs`]).
    pub matched_pairs: Vec<(usize, usize)>,
}

/// [`SessionScore`] of `track` localized by `method`.
pub fn score_session(
    track: &Track,
    flags: &[bool],
    model: &DetectorModel,
    method: Method,
    threshold: f64,
) -> SessionScore {
    let truth = true_segments(flags);
    let loc = localize::localize(track, model, method, threshold);
    let found: Vec<(f64, f64)> = loc.segments.iter().map(|s| (s.start_s, s.end_s)).collect();
    let pairs = matched_pairs(&found, &truth, MIN_IOU);
    let m = SegmentMatch::of_pairs(&found, &truth, &pairs);
    let mut s = SessionScore {
        segments_found: m.found,
        segments_true: m.truth,
        onset_errors_s: m.onset_errors_s,
        ..Default::default()
    };
    (s.start_offsets_s, s.end_offsets_s) =
        edge_offsets(&found, &truth, &pairs, flags.len() as f64 / FPS);
    s.found_segments = found;
    s.matched_pairs = pairs;
    for (k, &f) in flags.iter().enumerate() {
        let t = k as f64 / FPS;
        let called = s.found_segments.iter().any(|&(a, b)| a <= t && t < b) as usize;
        if f {
            s.reading_frames += 1;
            s.found_frames += called;
        } else {
            s.other_frames += 1;
            s.false_frames += called;
        }
    }
    s
}

/// Signed edge errors of the matched `pairs` ([`matched_pairs`]): found
/// start minus true start where the true stretch does not start at 0,
/// found end minus true end where it does not end with the session of
/// `session_end_s` (a session's edge cuts both alike and says nothing of
/// where the method puts an edge).
pub fn edge_offsets(
    found: &[(f64, f64)],
    truth: &[(f64, f64)],
    pairs: &[(usize, usize)],
    session_end_s: f64,
) -> (Vec<f64>, Vec<f64>) {
    let mut starts = Vec::new();
    let mut ends = Vec::new();
    for &(i, j) in pairs {
        let (f, t) = (found[i], truth[j]);
        if !starts_session(t.0) {
            starts.push(f.0 - t.0);
        }
        if !ends_session(t.1, session_end_s) {
            ends.push(f.1 - t.1);
        }
    }
    (starts, ends)
}

/// Whether a stretch starting at `start_s` starts with its session's
/// first frame.
fn starts_session(start_s: f64) -> bool {
    start_s < 0.5 / FPS
}

/// Whether a stretch ending at `end_s` runs to the last frame of a
/// session of `duration_s`.
fn ends_session(end_s: f64, duration_s: f64) -> bool {
    end_s >= duration_s - 0.5 / FPS
}

/// Sessions' scores pooled: segment F1 over all their segments (each
/// session matched on its own), onset errors, and frame shares.
pub fn pool<'a>(
    method: Method,
    scores: impl IntoIterator<Item = &'a SessionScore>,
) -> MethodResult {
    let mut sum = SessionScore::default();
    for s in scores {
        sum.segments_found += s.segments_found;
        sum.segments_true += s.segments_true;
        sum.onset_errors_s.extend(&s.onset_errors_s);
        sum.start_offsets_s.extend(&s.start_offsets_s);
        sum.end_offsets_s.extend(&s.end_offsets_s);
        sum.false_frames += s.false_frames;
        sum.other_frames += s.other_frames;
        sum.found_frames += s.found_frames;
        sum.reading_frames += s.reading_frames;
    }
    let pooled =
        SegmentMatch::from_counts(sum.segments_found, sum.segments_true, sum.onset_errors_s);
    let ratio = |m: usize, n: usize| if n == 0 { 1.0 } else { m as f64 / n as f64 };
    MethodResult {
        method,
        onset_error_median_s: eyereplay_signal::stats::median(&pooled.onset_errors_s),
        start_offset_median_s: eyereplay_signal::stats::median(&sum.start_offsets_s),
        end_offset_median_s: eyereplay_signal::stats::median(&sum.end_offsets_s),
        segments: pooled,
        false_reading_fraction: ratio(sum.false_frames, sum.other_frames),
        reading_recall: ratio(sum.found_frames, sum.reading_frames),
    }
}

/// Localizes every track by `method` and pools their scores ([`pool`]).
pub fn score_method(
    tracks: &[Track],
    flags: &[Vec<bool>],
    model: &DetectorModel,
    method: Method,
    threshold: f64,
) -> MethodResult {
    let scores: Vec<SessionScore> = tracks
        .iter()
        .zip(flags)
        .map(|(t, f)| score_session(t, f, model, method, threshold))
        .collect();
    pool(method, &scores)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn window_aurocs_pool_and_average_within_tracks() {
        // Recording 0: positives 0.9, 0.4 against negatives 0.5, 0.1: of
        // the four pairs three rank right, AUROC 0.75. Recording 1:
        // positive 0.3 against negative 0.2: 1.0. Recording 2 has only a
        // negative and counts for the pool alone. Pooled: positives 0.9,
        // 0.4, 0.3 against negatives 0.5, 0.1, 0.2, 0.6: 0.9 beats 4, 0.4
        // beats 2, 0.3 beats 2: 8 of 12.
        let p = [0.9, 0.4, 0.5, 0.1, 0.3, 0.2, 0.6];
        let l = [true, true, false, false, true, false, false];
        let rec = [0, 0, 0, 0, 1, 1, 2];
        let w = |p: &[f64], l: &[bool], rec: &[usize]| LabelledWindows {
            probability: p.to_vec(),
            reading: l.to_vec(),
            track: rec.to_vec(),
            features: vec![[0.0; FEATURE_COUNT]; p.len()],
        };
        let (pooled, within, n) = w(&p, &l, &rec).aurocs();
        assert!((pooled.unwrap() - 8.0 / 12.0).abs() < 1e-12);
        assert!((within.unwrap() - 0.875).abs() < 1e-12);
        assert_eq!(n, 2);
        assert_eq!(w(&[0.5], &[true], &[0]).aurocs(), (None, None, 0));
    }

    #[test]
    fn feature_aurocs_set_the_picked_reading_against_all_talk() {
        // Track 0 reads with feature 0 at 3 and 1, track 1 reads at 5; the
        // talk windows sit at 2 (track 0) and 0 (track 1). Track 0's
        // reading against all talk: 3 beats both, 1 beats 0 only: 3 of 4.
        // Track 1's: 5 beats both: 1.0, though track 1 has one talk window
        // of its own. Every reading window: 5 of 6. Feature 1 holds the
        // same value everywhere: ties, 0.5.
        let at = |v: f64| {
            let mut f = [7.0; FEATURE_COUNT];
            f[0] = v;
            f
        };
        let w = LabelledWindows {
            probability: vec![0.5; 5],
            reading: vec![true, true, false, true, false],
            track: vec![0, 0, 0, 1, 1],
            features: [3.0, 1.0, 2.0, 5.0, 0.0].map(at).to_vec(),
        };
        let first = w.feature_aurocs(|t| t == 0);
        assert_eq!(first.len(), FEATURE_COUNT);
        assert_eq!(first[0].feature, "forward_step_fraction_40ms");
        assert_eq!(first[0].auroc, Some(0.75));
        assert_eq!(first[1].auroc, Some(0.5));
        assert_eq!(w.feature_aurocs(|t| t == 1)[0].auroc, Some(1.0));
        let all = w.feature_aurocs(|_| true)[0].auroc.unwrap();
        assert!((all - 5.0 / 6.0).abs() < 1e-12);
        // No track picked: no reading window, no AUROC.
        assert_eq!(w.feature_aurocs(|_| false)[0].auroc, None);
    }

    #[test]
    fn answers_found_joined_and_cut_by_the_end_worked_by_hand() {
        let truth = [(10.0, 40.0), (60.0, 90.0), (150.0, 180.0)];
        // The first found segment fits the first answer (IoU 28 / 31); the
        // second runs from the second answer across 60 s of talk into the
        // third (IoU 30 / 102 and 10 / 122).
        let found = [(12.0, 41.0), (58.0, 160.0)];
        let a = answer_results(
            "c/c_0001.csv",
            Some("laptop"),
            &truth,
            &found,
            &matched_pairs(&found, &truth, MIN_IOU),
            180.0,
            Some(ExtractorMatched::None),
        );
        assert_eq!(a.len(), 3);
        assert!(a[0].found && !a[0].joined && !a[0].at_session_end);
        assert!((a[0].best_iou - 28.0 / 31.0).abs() < 1e-12);
        assert!(!a[1].found && a[1].joined);
        assert!((a[1].best_iou - 30.0 / 102.0).abs() < 1e-12);
        assert!(!a[2].found && a[2].joined && a[2].at_session_end);
        assert!((a[2].best_iou - 10.0 / 122.0).abs() < 1e-12);
        assert_eq!(a[2].surface.as_deref(), Some("laptop"));
        assert_eq!(a[2].extractor_match, Some(ExtractorMatched::None));
        // Nothing found: every answer missed, IoU 0, none joined.
        let none = answer_results("c", None, &truth, &[], &[], 180.0, None);
        assert!(none
            .iter()
            .all(|a| !a.found && a.best_iou == 0.0 && !a.joined));
        // One segment, two answers at IoU >= 0.5 each cannot both take it.
        let (truth2, found2) = ([(0.0, 10.0), (0.0, 9.0)], [(0.0, 10.0)]);
        let two = answer_results(
            "c",
            None,
            &truth2,
            &found2,
            &matched_pairs(&found2, &truth2, MIN_IOU),
            60.0,
            None,
        );
        assert_eq!(two.iter().filter(|a| a.found).count(), 1);
    }

    #[test]
    fn edge_offsets_are_signed_and_leave_out_the_sessions_edges() {
        // 100-s session. Answers [0, 30), [40, 60), [70, 100); found
        // [0, 28) (IoU 28/30), [42, 59) (17/20) and [68, 100) (30/32),
        // taken best IoU first (the third, the first, the second): starts
        // -2 (the third) and +2 (the second; the first starts the
        // session); ends -2 (the first) and -1 (the second; the third
        // ends the session). A found [80, 85) matches nothing and counts
        // for neither.
        let truth = [(0.0, 30.0), (40.0, 60.0), (70.0, 100.0)];
        let found = [(0.0, 28.0), (42.0, 59.0), (68.0, 100.0), (80.0, 85.0)];
        let pairs = matched_pairs(&found, &truth, MIN_IOU);
        let (starts, ends) = edge_offsets(&found, &truth, &pairs, 100.0);
        assert_eq!(starts, [-2.0, 2.0]);
        assert_eq!(ends, [-2.0, -1.0]);
        // Pooled: medians over every session's pairs.
        let score = |starts: Vec<f64>, ends: Vec<f64>| SessionScore {
            start_offsets_s: starts,
            end_offsets_s: ends,
            ..Default::default()
        };
        let r = pool(
            Method::HmmEdges,
            &[
                score(vec![2.0, -2.0], vec![-2.0, -1.0]),
                score(vec![3.0], vec![]),
            ],
        );
        assert_eq!(r.start_offset_median_s, Some(2.0));
        assert_eq!(r.end_offset_median_s, Some(-1.5));
        assert_eq!(pool(Method::Hmm, &[]).start_offset_median_s, None);
    }

    #[test]
    fn an_identity_file_says_whether_the_session_was_matched() {
        let dir = tempfile::tempdir().unwrap();
        let write = |name: &str, mapping: &str| {
            let path = dir.path().join(name);
            std::fs::write(
                &path,
                format!(
                    r#"{{"file": "c/c.csv", "seed": 1, "identity": {{}}, "mapping": {mapping}, "width": 640, "height": 480, "fps": 25.0}}"#
                ),
            )
            .unwrap();
            path
        };
        let matched = write(
            "m.json",
            r#"{"gain": 1.0, "extractor_response": {"a": [[1, 0], [0, 1]], "b": [0, 0]}}"#,
        );
        let unmatched = write("u.json", r#"{"gain": 1.0}"#);
        assert_eq!(
            extractor_matched(&matched).unwrap(),
            Some(ExtractorMatched::Both)
        );
        assert_eq!(
            extractor_matched(&unmatched).unwrap(),
            Some(ExtractorMatched::None)
        );
        assert_eq!(
            extractor_matched(&dir.path().join("none.json")).unwrap(),
            None
        );
        // One that cannot be read is named, not taken for "no file".
        let broken = dir.path().join("broken.json");
        std::fs::write(&broken, "{ not json").unwrap();
        let e = extractor_matched(&broken).unwrap_err().to_string();
        assert!(
            e.contains("broken.json") && e.contains("not an eyereplay identity file"),
            "{e}"
        );
        // One axis matched: the face mode names the other.
        let path = dir.path().join("h.json");
        std::fs::write(
            &path,
            r#"{"file": "c/c.csv", "seed": 1, "identity": {"geometric_axis": "vertical"}, "mapping": {"extractor_response": {"a": [[0.5, 0], [0, 1]], "b": [0.2, 0]}}, "width": 640, "height": 480, "fps": 25.0}"#,
        )
        .unwrap();
        assert_eq!(
            extractor_matched(&path).unwrap(),
            Some(ExtractorMatched::Horizontal)
        );
        // Serialized as the JSON says it.
        assert_eq!(
            serde_json::json!(ExtractorMatched::Horizontal),
            "horizontal"
        );
    }

    #[test]
    fn runs_of_flags_in_seconds() {
        let f = |s: &str| s.chars().map(|c| c == '1').collect::<Vec<_>>();
        // At 25 fps: frames 25..50 and 75..100 (the end).
        let flags = f(&("0".repeat(25) + &"1".repeat(25) + &"0".repeat(25) + &"1".repeat(25)));
        assert_eq!(true_runs(&flags), [(1.0, 2.0), (3.0, 4.0)]);
        assert!(true_runs(&f("000")).is_empty());
        // Only stretches of at least 5 s are scored against: the 1-s runs
        // go, a 6-s one stays.
        assert!(true_segments(&flags).is_empty());
        let long = f(&("0".repeat(10) + &"1".repeat(150)));
        assert_eq!(true_segments(&long), [(0.4, 6.4)]);
    }

    #[test]
    fn surfaces_and_line_angles_from_metadata() {
        let dir = tempfile::tempdir().unwrap();
        // An 80-character line of 2.5 mm characters at 60 cm spans
        // 2 atan(100 / 600) = 18.92 deg (the behaviour study's worked
        // value); the talker has no plane and is left out.
        let meta = r#"{"sources": [
            {"id": "interview_model#conversation/0/0", "behaviour": {"params": {"plane": {
                "surface": "laptop", "line_chars": 80, "char_width_mm": 2.5,
                "centre_mm": [0.0, 0.0, 600.0]}}}},
            {"id": "conversation_model#conversation/0/1", "behaviour": {"params": {"model": "conversation"}}}
        ]}"#;
        std::fs::write(dir.path().join("metadata.json"), meta).unwrap();
        let map = source_surfaces(dir.path()).unwrap();
        assert_eq!(map.len(), 1);
        let s = &map["interview_model#conversation/0/0"];
        assert_eq!(s.surface, "laptop");
        assert!(
            (s.line_span_deg - 18.92).abs() < 0.01,
            "{}",
            s.line_span_deg
        );
        // No metadata: no breakdown, no error; broken metadata: an error naming it.
        let empty = tempfile::tempdir().unwrap();
        assert!(source_surfaces(empty.path()).unwrap().is_empty());
        std::fs::write(empty.path().join("metadata.json"), "{").unwrap();
        let e = source_surfaces(empty.path()).unwrap_err().to_string();
        assert!(e.contains("metadata.json"), "{e}");
    }

    #[test]
    fn surface_groups_split_the_sessions_and_their_segments() {
        use eyereplay_detect::model::{train, Example, TrainOptions};
        // Reading: a sawtooth of 10 steps a line; talking: a slow wander.
        let reading = |n: usize| -> Vec<[f64; 2]> {
            (0..n)
                .map(|i| [((i % 50) / 5) as f64, (i / 50) as f64 * 0.1])
                .collect()
        };
        let talking = |n: usize| -> Vec<[f64; 2]> {
            (0..n)
                .map(|i| [(i as f64 / 40.0).sin() * 4.0, (i as f64 / 70.0).cos()])
                .collect()
        };
        let mut examples = Vec::new();
        for k in 0..8 {
            for (xy, r) in [(reading(250), true), (talking(250), false)] {
                let xy: Vec<[f64; 2]> = xy.iter().map(|p| [p[0] + k as f64 * 0.01, p[1]]).collect();
                let w = eyereplay_detect::window::prepare_window(&xy, 0).unwrap();
                examples.push(Example::of(&w, r, &format!("p{k}{r}")));
            }
        }
        let model = train(
            &examples,
            10.0,
            TrainOptions {
                classifier: eyereplay_detect::Classifier::LogisticRegression,
                ..TrainOptions::default()
            },
            vec![],
            "trajectory",
        )
        .unwrap();
        // Two sessions: 40 s talk + 40 s reading, and 80 s of talk.
        let mut a = talking(1000);
        a.extend(reading(1000));
        let fa: Vec<bool> = (0..2000).map(|i| i >= 1000).collect();
        let tracks = [Track::new(a), Track::new(talking(2000))];
        let flags = [fa, vec![false; 2000]];
        let s = |n: &str| {
            Some(SourceSurface {
                surface: n.into(),
                line_span_deg: 10.0,
            })
        };
        let hmm: Vec<SessionScore> = tracks
            .iter()
            .zip(&flags)
            .map(|(t, f)| score_session(t, f, &model, Method::Hmm, 0.5))
            .collect();
        let labelled = LabelledWindows::of(&tracks, &flags, &model);
        // 10-s windows: the first session's 4 talk and 4 reading (the
        // switch falls on a window edge), the second's 8 talk.
        assert_eq!(
            labelled.track,
            [0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 1, 1, 1, 1]
        );
        assert_eq!(labelled.reading.iter().filter(|&&r| r).count(), 4);
        let groups = by_surface(&hmm, &[s("laptop"), s("teleprompter")], &labelled);
        // The laptop session's reading windows all rank over its talk
        // windows; the teleprompter session has no reading window.
        assert_eq!(groups[0].window_auroc, Some(1.0));
        assert_eq!(groups[1].window_auroc, None);
        // The sawtooth's 200-ms steps go forward but at a line's end; the
        // wander's as often back. The teleprompter session has no reading
        // to score.
        assert_eq!(
            groups[0].feature_auroc[1].feature,
            "forward_step_fraction_200ms"
        );
        assert!(groups[0].feature_auroc[1].auroc.unwrap() > 0.9);
        assert_eq!(groups[1].feature_auroc[0].auroc, None);
        assert_eq!(groups.len(), 2);
        assert_eq!(groups[0].surface, "laptop");
        assert_eq!(groups[0].result.segments.truth, 1);
        assert_eq!(groups[1].result.segments.truth, 0);
        let all = score_method(&tracks, &flags, &model, Method::Hmm, 0.5);
        let found: usize = groups.iter().map(|g| g.result.segments.found).sum();
        assert_eq!(found, all.segments.found);
        assert_eq!(groups[0].result.segments.matched, 1);
        assert_eq!(all.segments.matched, 1);
    }
}
