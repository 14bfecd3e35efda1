//! When, not only whether: a reading probability per frame and reading
//! segments with start, end and confidence, for a recording of any length
//! (an interview may read one answer among minutes of talk).
//!
//! Two ways from window scores to frames, compared in docs/DETECTOR.md:
//! - [`frame_probabilities`]: each frame gets the mean probability of the
//!   overlapping windows that cover it;
//! - [`hmm_posterior`]: those per-frame probabilities as the evidence of a
//!   two-state hidden Markov model (reading / not reading) whose states
//!   last [`MEAN_DWELL_S`] on average, smoothed by forward-backward.
//!
//! [`segments`] cuts the result into segments; [`match_segments`] scores
//! them against known ones (F1 at an IoU threshold, onset errors).

use crate::model::DetectorModel;
use crate::window::{windows, Track, WindowSpec, FPS, MAX_MISSING_FRACTION};
use serde::{Deserialize, Serialize};

/// Mean duration of a reading or a talking spell in an interview, for the
/// hidden Markov model's switching probability: about one answer.
pub const MEAN_DWELL_S: f64 = 30.0;

/// Distance between the starts of the overlapping windows localization
/// scores: one second.
pub const STRIDE_S: f64 = 1.0;

/// Reading segments shorter than this are dropped (a few seconds of
/// reading-like gaze while talking is not a read answer).
pub const MIN_SEGMENT_S: f64 = 5.0;

/// Where segments are cut by default: the per-frame probability of
/// reading (the HMM's posterior) reaching one half.
pub const SEGMENT_THRESHOLD: f64 = 0.5;

/// Gaps up to this long inside a reading segment are bridged (a glance to
/// the camera between two lines of a script).
pub const MAX_GAP_S: f64 = 4.0;

/// How window scores become per-frame probabilities.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Method {
    /// The mean of the overlapping windows covering each frame.
    WindowMean,
    /// Those means smoothed by the two-state hidden Markov model.
    Hmm,
}

/// A recording's reading probability over time and its reading segments.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Localization {
    pub method: Method,
    /// One value per `step_s` (the mean of that second's frames); `null`
    /// where no window could be scored (too little gaze).
    pub step_s: f64,
    pub probability: Vec<Option<f64>>,
    pub segments: Vec<Segment>,
    /// Stretches of at least a second that no window could score: nothing
    /// is said of them, and this says why.
    #[serde(default)]
    pub unscored: Vec<Unscored>,
}

/// A stretch without a reading probability: too little gaze for a window.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Unscored {
    pub start_s: f64,
    pub end_s: f64,
    /// Seconds with gaze in it.
    pub usable_s: f64,
    /// Gaze one window needs.
    pub needed_s: f64,
}

/// Scores `track` with windows of the model's length every
/// [`STRIDE_S`], turns them into per-frame probabilities by `method`, and
/// cuts segments where they reach `threshold` ([`SEGMENT_THRESHOLD`]
/// unless measured otherwise).
pub fn localize(
    track: &Track,
    model: &DetectorModel,
    method: Method,
    threshold: f64,
) -> Localization {
    let frame_p = frame_probability(track, model, method);
    localization_of(track, &frame_p, model, method, threshold)
}

/// [`localize`] from per-frame probabilities already computed by
/// [`frame_probability`] (for callers that need both).
pub fn localization_of(
    track: &Track,
    frame_p: &[f64],
    model: &DetectorModel,
    method: Method,
    threshold: f64,
) -> Localization {
    let segments = segments(frame_p, FPS, threshold, MIN_SEGMENT_S, MAX_GAP_S);
    let per_step = FPS.round() as usize;
    let probability = frame_p
        .chunks(per_step)
        .map(|c| {
            let v: Vec<f64> = c.iter().copied().filter(|p| p.is_finite()).collect();
            (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
        })
        .collect();
    let needed_s = model.window_s * (1.0 - MAX_MISSING_FRACTION);
    let unscored = runs(frame_p.iter().map(|p| !p.is_finite()))
        .into_iter()
        .filter(|&(a, b)| (b - a) as f64 >= FPS)
        .map(|(a, b)| Unscored {
            start_s: a as f64 / FPS,
            end_s: b as f64 / FPS,
            usable_s: track.xy[a..b]
                .iter()
                .filter(|p| p[0].is_finite() && p[1].is_finite())
                .count() as f64
                / FPS,
            needed_s,
        })
        .collect();
    Localization {
        method,
        step_s: per_step as f64 / FPS,
        probability,
        segments,
        unscored,
    }
}

/// The per-frame reading probability of `track` by `method`.
pub fn frame_probability(track: &Track, model: &DetectorModel, method: Method) -> Vec<f64> {
    let spec = WindowSpec {
        step: (STRIDE_S * FPS).round() as usize,
        ..WindowSpec::seconds(model.window_s)
    };
    let scored: Vec<ScoredWindow> = windows(track, spec)
        .iter()
        .map(|w| ScoredWindow {
            start: w.start,
            frames: spec.frames,
            probability: model.probability(w),
        })
        .collect();
    let mean = frame_probabilities(track.len(), &scored);
    match method {
        Method::WindowMean => mean,
        Method::Hmm => {
            let post = hmm_posterior(&mean, FPS, MEAN_DWELL_S, spec.frames);
            // Where no window reaches, there is nothing to say.
            post.into_iter()
                .zip(&mean)
                .map(|(q, m)| if m.is_finite() { q } else { f64::NAN })
                .collect()
        }
    }
}

/// A scored window: first frame, length in frames, reading probability.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScoredWindow {
    pub start: usize,
    pub frames: usize,
    pub probability: f64,
}

/// Per frame of a track of `n_frames`: the mean probability of the windows
/// that cover it; NaN where none does (a gap with no scorable window).
pub fn frame_probabilities(n_frames: usize, windows: &[ScoredWindow]) -> Vec<f64> {
    let mut sum = vec![0.0; n_frames];
    let mut count = vec![0u32; n_frames];
    for w in windows {
        for k in w.start..(w.start + w.frames).min(n_frames) {
            sum[k] += w.probability;
            count[k] += 1;
        }
    }
    sum.iter()
        .zip(&count)
        .map(|(&s, &c)| if c == 0 { f64::NAN } else { s / c as f64 })
        .collect()
}

/// The posterior probability of reading per frame under a two-state hidden
/// Markov model: the state switches with probability `1 / (mean_dwell_s *
/// fps)` per frame, and a frame's evidence is its probability `p` read as
/// the likelihood ratio `p / (1 - p)` (the detector is trained on balanced
/// classes, so its odds are likelihood ratios), tempered to the power `1 /
/// evidence_frames`: neighbouring frames share the same windows, so one
/// window's worth of frames (`evidence_frames`, its length) counts as one
/// observation, not hundreds. NaN frames carry no evidence.
/// Forward-backward with per-step normalization.
pub fn hmm_posterior(
    frame_p: &[f64],
    fps: f64,
    mean_dwell_s: f64,
    evidence_frames: usize,
) -> Vec<f64> {
    let n = frame_p.len();
    if n == 0 {
        return Vec::new();
    }
    let switch = (1.0 / (mean_dwell_s * fps).max(1.0)).clamp(1e-9, 0.5);
    let stay = 1.0 - switch;
    let temper = 1.0 / evidence_frames.max(1) as f64;
    // Evidence per frame: (likelihood if reading, if not), clipped so that
    // one confident window cannot decide alone.
    let lik = |p: f64| -> [f64; 2] {
        if p.is_finite() {
            let p = p.clamp(0.01, 0.99);
            [p.powf(temper), (1.0 - p).powf(temper)]
        } else {
            [1.0, 1.0]
        }
    };
    let norm = |v: [f64; 2]| {
        let s = v[0] + v[1];
        [v[0] / s, v[1] / s]
    };
    let mut fwd = vec![[0.5, 0.5]; n];
    let l0 = lik(frame_p[0]);
    fwd[0] = norm([0.5 * l0[0], 0.5 * l0[1]]);
    for t in 1..n {
        let a = fwd[t - 1];
        let prior = [a[0] * stay + a[1] * switch, a[1] * stay + a[0] * switch];
        let l = lik(frame_p[t]);
        fwd[t] = norm([prior[0] * l[0], prior[1] * l[1]]);
    }
    let mut bwd = vec![[1.0, 1.0]; n];
    for t in (0..n - 1).rev() {
        let l = lik(frame_p[t + 1]);
        let b = bwd[t + 1];
        let next = [l[0] * b[0], l[1] * b[1]];
        bwd[t] = norm([
            stay * next[0] + switch * next[1],
            switch * next[0] + stay * next[1],
        ]);
    }
    fwd.iter()
        .zip(&bwd)
        .map(|(f, b)| {
            let r = f[0] * b[0];
            let o = f[1] * b[1];
            r / (r + o)
        })
        .collect()
}

/// A reading segment.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Segment {
    pub start_s: f64,
    pub end_s: f64,
    /// Mean per-frame probability over the segment.
    pub confidence: f64,
}

impl Segment {
    pub fn duration_s(&self) -> f64 {
        self.end_s - self.start_s
    }
}

/// Runs of frames whose probability reaches `threshold`; runs closer than
/// `max_gap_s` are joined (a blink or a glance up does not end a read
/// answer), and what is then shorter than `min_len_s` is dropped. NaN
/// frames are not reading.
pub fn segments(
    frame_p: &[f64],
    fps: f64,
    threshold: f64,
    min_len_s: f64,
    max_gap_s: f64,
) -> Vec<Segment> {
    let runs = runs(frame_p.iter().map(|&p| p.is_finite() && p >= threshold));
    let max_gap = (max_gap_s * fps).round() as usize;
    let mut joined: Vec<(usize, usize)> = Vec::new();
    for r in runs {
        match joined.last_mut() {
            Some(last) if r.0 - last.1 <= max_gap => last.1 = r.1,
            _ => joined.push(r),
        }
    }
    joined
        .into_iter()
        .filter(|(a, b)| (b - a) as f64 / fps >= min_len_s)
        .map(|(a, b)| {
            let vals: Vec<f64> = frame_p[a..b]
                .iter()
                .copied()
                .filter(|p| p.is_finite())
                .collect();
            Segment {
                start_s: a as f64 / fps,
                end_s: b as f64 / fps,
                confidence: vals.iter().sum::<f64>() / vals.len().max(1) as f64,
            }
        })
        .collect()
}

/// The runs of `true` in `flags`, as `[start, end)` frame ranges.
pub fn runs(flags: impl IntoIterator<Item = bool>) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut start = None;
    let mut n = 0;
    for (k, on) in flags.into_iter().enumerate() {
        match (on, start) {
            (true, None) => start = Some(k),
            (false, Some(s)) => {
                out.push((s, k));
                start = None;
            }
            _ => {}
        }
        n = k + 1;
    }
    if let Some(s) = start {
        out.push((s, n));
    }
    out
}

/// Intersection over union of two time spans.
pub fn iou(a: (f64, f64), b: (f64, f64)) -> f64 {
    let inter = (a.1.min(b.1) - a.0.max(b.0)).max(0.0);
    let union = (a.1 - a.0) + (b.1 - b.0) - inter;
    if union <= 0.0 {
        0.0
    } else {
        inter / union
    }
}

/// How found segments match known ones.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SegmentMatch {
    pub found: usize,
    pub truth: usize,
    /// Pairs with IoU at least the threshold, each segment used once.
    pub matched: usize,
    pub precision: f64,
    pub recall: f64,
    pub f1: f64,
    /// |found start - true start| of each matched pair, seconds.
    pub onset_errors_s: Vec<f64>,
}

/// One-to-one matching, best IoU first, of `found` against `truth` spans;
/// a pair counts when its IoU reaches `min_iou`. Precision and recall are 1
/// when there is nothing to find and nothing was found.
pub fn match_segments(found: &[(f64, f64)], truth: &[(f64, f64)], min_iou: f64) -> SegmentMatch {
    let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
    for (i, f) in found.iter().enumerate() {
        for (j, t) in truth.iter().enumerate() {
            let v = iou(*f, *t);
            if v >= min_iou {
                pairs.push((v, i, j));
            }
        }
    }
    // Best IoU first; ties by position, so the result is deterministic.
    pairs.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
    let (mut used_f, mut used_t) = (vec![false; found.len()], vec![false; truth.len()]);
    let mut onset_errors_s = Vec::new();
    for (_, i, j) in pairs {
        if !used_f[i] && !used_t[j] {
            used_f[i] = true;
            used_t[j] = true;
            onset_errors_s.push((found[i].0 - truth[j].0).abs());
        }
    }
    SegmentMatch::from_counts(found.len(), truth.len(), onset_errors_s)
}

impl SegmentMatch {
    /// Precision, recall and F1 of `found` segments against `truth`, one
    /// onset error per matched pair; both 1 when there is nothing to find
    /// and nothing was found.
    pub fn from_counts(found: usize, truth: usize, onset_errors_s: Vec<f64>) -> SegmentMatch {
        let matched = onset_errors_s.len();
        let ratio = |m: usize, n: usize| if n == 0 { 1.0 } else { m as f64 / n as f64 };
        let precision = ratio(matched, found);
        let recall = ratio(matched, truth);
        let f1 = if precision + recall > 0.0 {
            2.0 * precision * recall / (precision + recall)
        } else {
            0.0
        };
        SegmentMatch {
            found,
            truth,
            matched,
            precision,
            recall,
            f1,
            onset_errors_s,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_take_the_mean_of_the_windows_covering_them() {
        let w = |start, probability| ScoredWindow {
            start,
            frames: 4,
            probability,
        };
        // Windows [0,4) p=0.2 and [2,6) p=0.8 over 8 frames.
        let p = frame_probabilities(8, &[w(0, 0.2), w(2, 0.8)]);
        assert_eq!(&p[..6], &[0.2, 0.2, 0.5, 0.5, 0.8, 0.8]);
        assert!(p[6].is_nan() && p[7].is_nan());
    }

    #[test]
    fn segments_join_short_gaps_and_drop_short_runs() {
        // fps 1: frames are seconds.
        let mut p = vec![0.0; 20];
        for k in (2..8).chain(9..12) {
            p[k] = 0.9;
        }
        p[15] = 0.95; // a lone frame
        p[9] = f64::NAN; // no evidence: not reading, inside the gap
        let s = segments(&p, 1.0, 0.5, 3.0, 2.0);
        assert_eq!(s.len(), 1);
        assert_eq!((s[0].start_s, s[0].end_s), (2.0, 12.0));
        // Mean over the finite frames of [2, 12): eight at 0.9, one at 0.
        assert!((s[0].confidence - 0.8).abs() < 1e-12, "{}", s[0].confidence);
        // Without joining, the two runs are 6 s and 2 s: only one is kept.
        let s = segments(&p, 1.0, 0.5, 3.0, 0.0);
        assert_eq!(
            s.iter().map(|s| (s.start_s, s.end_s)).collect::<Vec<_>>(),
            [(2.0, 8.0)]
        );
        // A run reaching the end is closed there.
        let s = segments(&[0.0, 0.9, 0.9], 1.0, 0.5, 0.0, 0.0);
        assert_eq!((s[0].start_s, s[0].end_s), (1.0, 3.0));
    }

    #[test]
    fn iou_and_matching_by_hand() {
        assert_eq!(iou((0.0, 10.0), (5.0, 15.0)), 5.0 / 15.0);
        assert_eq!(iou((0.0, 1.0), (2.0, 3.0)), 0.0);
        assert_eq!(iou((0.0, 10.0), (0.0, 10.0)), 1.0);
        // Truth: two read answers; found: one good, one shifted too far,
        // and a false alarm.
        let truth = [(10.0, 40.0), (100.0, 130.0)];
        let found = [(12.0, 41.0), (120.0, 150.0), (200.0, 210.0)];
        let m = match_segments(&found, &truth, 0.5);
        // (12,41) vs (10,40): 28 / 31 = 0.90; (120,150) vs (100,130): 10 / 50.
        assert_eq!(m.matched, 1);
        assert_eq!((m.precision, m.recall), (1.0 / 3.0, 0.5));
        assert!((m.f1 - 0.4).abs() < 1e-12);
        assert_eq!(m.onset_errors_s, [2.0]);
        // Nothing to find, nothing found: perfect.
        let m = match_segments(&[], &[], 0.5);
        assert_eq!((m.precision, m.recall, m.f1), (1.0, 1.0, 1.0));
        // One found segment cannot match two true ones.
        let m = match_segments(&[(0.0, 10.0)], &[(0.0, 10.0), (0.0, 9.0)], 0.5);
        assert_eq!(m.matched, 1);
    }

    #[test]
    fn the_hmm_keeps_a_step_and_smooths_a_flicker() {
        let fps = 25.0;
        // 60 s reading (0.8) then 60 s talking (0.2), with a 1 s flicker of
        // 0.9 inside the talk.
        let mut p: Vec<f64> = (0..3000)
            .map(|k| if k < 1500 { 0.8 } else { 0.2 })
            .collect();
        for v in &mut p[2200..2225] {
            *v = 0.9;
        }
        // 10 s windows: 250 frames make one observation.
        let post = hmm_posterior(&p, fps, MEAN_DWELL_S, 250);
        // Sure away from the step and the start (the posterior ramps over
        // about one window: 300 frames of 0.8 are only 4^1.2 in favour).
        assert!(
            post[250..1000].iter().all(|&q| q > 0.9),
            "{} {}",
            post[250],
            post[1000]
        );
        assert!(post[2000..2150].iter().all(|&q| q < 0.1), "{}", post[2000]);
        // The flicker does not make a segment.
        assert!(post[2200..2225].iter().all(|&q| q < 0.5), "{}", post[2212]);
        // The switch is placed at the step, to a frame or two.
        let cross = post.iter().position(|&q| q < 0.5).unwrap();
        assert!((cross as i64 - 1500).abs() <= 2, "{cross}");
        // Symmetric: the complement input gives the complement posterior.
        let q: Vec<f64> = p.iter().map(|v| 1.0 - v).collect();
        let post_q = hmm_posterior(&q, fps, MEAN_DWELL_S, 250);
        for (a, b) in post.iter().zip(&post_q) {
            assert!((a + b - 1.0).abs() < 1e-9);
        }
        // No evidence at all: the prior, one half.
        let none = hmm_posterior(&[f64::NAN; 10], fps, MEAN_DWELL_S, 250);
        // Untempered (one frame, one observation), the flicker would win:
        // why the evidence is tempered.
        let raw = hmm_posterior(&p, fps, MEAN_DWELL_S, 1);
        assert!(raw[2212] > 0.5, "{}", raw[2212]);
        assert!(none.iter().all(|&q| (q - 0.5).abs() < 1e-12));
    }
}
