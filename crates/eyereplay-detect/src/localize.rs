//! When, not only whether: a reading probability per frame and reading
//! segments with start, end and confidence, for a recording of any length
//! (an interview may read one answer among minutes of talk).
//!
//! Two ways from window scores to frames, compared in docs/DETECTOR.md:
//! - [`frame_probabilities`]: each frame gets the mean probability of the
//!   overlapping windows that cover it;
//! - [`hmm_posterior`]: those per-frame probabilities as the evidence of a
//!   two-state hidden Markov model (reading / not reading) whose states
//!   last [`MEAN_DWELL_S`] on average, smoothed by forward-backward;
//! - the HMM's segments with each end moved to where the window mean
//!   crosses half-way between its levels inside and outside the segment,
//!   nearby ([`refine_edges`]): the HMM decides which segments there are,
//!   the window mean where they start and end (and where a segment holds
//!   a window or more of talk, [`split_at_dips`]), and only then is a
//!   segment under [`MIN_SEGMENT_S`] dropped (the HMM's own span of a
//!   short read answer is shorter than the answer: its evidence builds up
//!   over a window and its states last half a minute).
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
    /// The HMM's segments, each end moved to the nearest crossing of the
    /// window mean, within one window, half-way between its levels inside
    /// and outside the segment ([`refine_edges`]). The HMM's evidence is
    /// tempered to one observation a window and its states last half a
    /// minute, so its edges lag a change by seconds; the window mean of a
    /// step is half-way at the step, but alone it cuts short false
    /// segments the HMM does not. An HMM segment of any length is moved,
    /// and cut where the window mean holds talk's level for a window;
    /// what is then under [`MIN_SEGMENT_S`] is dropped.
    HmmEdges,
}

impl Method {
    /// Every method, in the order the evaluations print them.
    pub const ALL: [Method; 3] = [Method::WindowMean, Method::Hmm, Method::HmmEdges];
}

/// What `eyereplay detect` localizes with: on held-out generated
/// interviews it finds what [`Method::Hmm`] finds with a median onset error
/// of 1.9 s against 3.3, and on real reading spliced between other
/// people's tasks loses one match of 58 (docs/DETECTOR.md).
pub const DEFAULT_METHOD: Method = Method::HmmEdges;

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
    /// The mean score of the windows covering each frame, per `step_s` as
    /// `probability`: what [`Method::HmmEdges`] finds the segments' ends
    /// on (for [`Method::WindowMean`], `probability` itself). A segment can
    /// span more than the stretch where `probability` passes one half:
    /// this shows why. Empty in results written before it was kept.
    #[serde(default)]
    pub window_mean: Vec<Option<f64>>,
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

impl Unscored {
    /// Why the stretch has no score, for people (`detect`'s log, the
    /// reviewer's page): too little gaze in it, or enough gaze cut up by
    /// gaps so that no whole window of `window_s` holds `needed_s` of it.
    pub fn reason(&self, window_s: f64) -> String {
        if self.usable_s >= self.needed_s {
            format!(
                "no score: gaze gaps leave no whole {window_s} s window with gaze in {:.1} s of it",
                self.needed_s
            )
        } else {
            format!(
                "not enough gaze: {:.1} s usable, {:.1} s needed within one {window_s} s window",
                self.usable_s, self.needed_s
            )
        }
    }
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
    localize_frames(track, model, method, threshold).1
}

/// [`localize`], with the per-frame probability it cut the segments from
/// (NaN where no window reaches; the HMM's posterior for both HMM methods,
/// since [`Method::HmmEdges`] moves only the segments' ends).
pub fn localize_frames(
    track: &Track,
    model: &DetectorModel,
    method: Method,
    threshold: f64,
) -> (Vec<f64>, Localization) {
    let (mean, window_frames) = window_mean(track, model);
    let frame_p = match method {
        Method::WindowMean => mean.clone(),
        Method::Hmm | Method::HmmEdges => hmm_of(&mean, window_frames),
    };
    let segments = match method {
        Method::WindowMean | Method::Hmm => {
            segments(&frame_p, FPS, threshold, MIN_SEGMENT_S, MAX_GAP_S)
        }
        Method::HmmEdges => edge_segments(&mean, &frame_p, FPS, threshold, window_frames),
    };
    let loc = localization_of(track, &frame_p, &mean, segments, model, method);
    (frame_p, loc)
}

/// [`Method::HmmEdges`]' segments: every run of the HMM's posterior
/// `frame_p` over `threshold`, however short (gaps up to [`MAX_GAP_S`]
/// bridged), moved to its edges on the window `mean` ([`refine_edges`],
/// within one window of `window_frames`); then what is under
/// [`MIN_SEGMENT_S`] is dropped.
///
/// The length rule comes after the move, not before: the posterior of a
/// 20-s answer among talk may pass one half for only a few seconds (its
/// evidence is tempered to one observation a window, and a state lasts
/// half a minute on average), while the window mean it is moved on spans
/// the answer. Before it, a segment is also cut where the window mean
/// stays at talk's level for a window or longer ([`split_at_dips`]): the
/// same slowness can carry the posterior over a short talk between two
/// answers.
pub fn edge_segments(
    mean: &[f64],
    frame_p: &[f64],
    fps: f64,
    threshold: f64,
    window_frames: usize,
) -> Vec<Segment> {
    let candidates = segments(frame_p, fps, threshold, 0.0, MAX_GAP_S);
    let moved = refine_edges(
        &candidates,
        mean,
        frame_p,
        fps,
        threshold,
        window_frames,
        MIN_SEGMENT_S,
    );
    split_at_dips(&moved, mean, frame_p, fps, threshold, window_frames)
        .into_iter()
        // Durations are whole frames; half a frame absorbs the division.
        .filter(|s| s.duration_s() >= MIN_SEGMENT_S - 0.5 / fps)
        .collect()
}

/// Each segment cut where the window `mean` stays below its level for at
/// least `min_dip` frames (one window): half-way between the median of
/// the mean inside the segment and its median outside every segment (the
/// recording's level of not reading; `threshold` where either is
/// missing). The pieces keep the segment's outer ends; the dips go; each
/// piece's confidence is `frame_p`'s mean over it.
///
/// The mirror of the short-answer case [`edge_segments`] handles: two read
/// answers with 15-20 s of talk between them can keep the HMM's posterior
/// over one half throughout (a state lasts half a minute), while the
/// window mean falls to talk's level for the talk's length. A dip shorter
/// than one window (a glance away, a pause between lines) is not talk.
pub fn split_at_dips(
    segments: &[Segment],
    mean: &[f64],
    frame_p: &[f64],
    fps: f64,
    threshold: f64,
    min_dip: usize,
) -> Vec<Segment> {
    let n = mean.len();
    let frame = |s: f64| ((s * fps).round() as usize).min(n);
    let spans: Vec<(usize, usize)> = segments
        .iter()
        .map(|s| (frame(s.start_s), frame(s.end_s)))
        .collect();
    let finite_median = |v: Vec<f64>| {
        let v: Vec<f64> = v.into_iter().filter(|p| p.is_finite()).collect();
        eyereplay_signal::stats::median(&v)
    };
    let outside = finite_median(
        (0..n)
            .filter(|&k| !spans.iter().any(|&(a, b)| a <= k && k < b))
            .map(|k| mean[k])
            .collect(),
    );
    let confidence = |a: usize, b: usize| {
        let v: Vec<f64> = frame_p[a..b]
            .iter()
            .copied()
            .filter(|p| p.is_finite())
            .collect();
        v.iter().sum::<f64>() / v.len().max(1) as f64
    };
    let mut out = Vec::with_capacity(segments.len());
    for &(a, b) in &spans {
        let level = match (finite_median(mean[a..b].to_vec()), outside) {
            (Some(i), Some(o)) => 0.5 * (i + o),
            _ => threshold,
        };
        let dips = runs(mean[a..b].iter().map(|&p| p.is_finite() && p < level))
            .into_iter()
            .filter(|&(x, y)| y - x >= min_dip.max(1))
            .map(|(x, y)| (a + x, a + y));
        let mut start = a;
        for (x, y) in dips.chain(std::iter::once((b, b))) {
            if x > start {
                out.push(Segment {
                    start_s: start as f64 / fps,
                    end_s: x as f64 / fps,
                    confidence: confidence(start, x),
                });
            }
            start = y;
        }
    }
    out
}

/// The localization of `segments`: the per-second probability and window
/// mean, and the stretches no window scores.
fn localization_of(
    track: &Track,
    frame_p: &[f64],
    mean: &[f64],
    segments: Vec<Segment>,
    model: &DetectorModel,
    method: Method,
) -> Localization {
    let per_step = FPS.round() as usize;
    let per_second = |frames: &[f64]| -> Vec<Option<f64>> {
        frames
            .chunks(per_step)
            .map(|c| {
                let v: Vec<f64> = c.iter().copied().filter(|p| p.is_finite()).collect();
                (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
            })
            .collect()
    };
    let probability = per_second(frame_p);
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
        window_mean: per_second(mean),
    }
}

/// The mean probability of the windows covering each frame, windows of the
/// model's length every [`STRIDE_S`]; and the window's length in frames.
fn window_mean(track: &Track, model: &DetectorModel) -> (Vec<f64>, usize) {
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
    (frame_probabilities(track.len(), &scored), spec.frames)
}

/// The HMM's posterior of the window means; NaN where no window reaches
/// (there is nothing to say there).
fn hmm_of(mean: &[f64], window_frames: usize) -> Vec<f64> {
    hmm_posterior(mean, FPS, MEAN_DWELL_S, window_frames)
        .into_iter()
        .zip(mean)
        .map(|(q, m)| if m.is_finite() { q } else { f64::NAN })
        .collect()
}

/// Each segment's ends moved to where the window mean crosses half-way
/// between its level inside the segment and its level outside.
///
/// A window-mean step from level `l_out` to `l_in` is a ramp over one
/// window on each side of the change, half-way at the change itself; a
/// fixed threshold of one half is crossed late where the two levels are
/// not symmetric about it (reading windows of a small text score lower
/// than talking windows score low). So each edge's level is the midpoint of
/// the median window mean inside the segment and the median over the
/// window beyond one window outside it (before a start, after an end; not
/// past a neighbouring segment); without enough of that (at least half a
/// window of values), `threshold`. The start moves to the nearest frame
/// within `reach` where the mean rises to that level (from below, or from
/// no value), the end to the nearest where it falls below; an edge with no
/// such crossing in reach stays. A start never moves before the previous
/// segment's end, an end never past the next segment's start, and a
/// segment the moves would make shorter than `min_len_s` keeps its own
/// ends. The confidence is `frame_p`'s mean over the new span (`mean` and
/// `frame_p` hold one value per frame of the same track).
pub fn refine_edges(
    segments: &[Segment],
    mean: &[f64],
    frame_p: &[f64],
    fps: f64,
    threshold: f64,
    reach: usize,
    min_len_s: f64,
) -> Vec<Segment> {
    let n = mean.len();
    let level_of = |a: usize, b: usize| -> Option<f64> {
        if a >= b.min(n) {
            return None;
        }
        let v: Vec<f64> = mean[a..b.min(n)]
            .iter()
            .copied()
            .filter(|p| p.is_finite())
            .collect();
        if v.len() * 2 < reach.max(1) {
            return None;
        }
        eyereplay_signal::stats::median(&v)
    };
    let above = |k: usize, level: f64| mean[k].is_finite() && mean[k] >= level;
    // The crossing of `level` (rising when `rise`) nearest to `at` within
    // reach, inside [lo, hi].
    let nearest = |at: usize, level: f64, rise: bool, lo: usize, hi: usize| -> Option<usize> {
        let from = at.saturating_sub(reach).max(lo).max(1);
        let to = (at + reach).min(hi).min(n.saturating_sub(1));
        (from..=to)
            .filter(|&k| above(k, level) == rise && above(k - 1, level) != rise)
            .min_by_key(|&k| (k.abs_diff(at), k))
    };
    let frame = |s: f64| ((s * fps).round() as usize).min(n);
    let mut out: Vec<Segment> = Vec::with_capacity(segments.len());
    for (i, s) in segments.iter().enumerate() {
        let (a, b) = (frame(s.start_s), frame(s.end_s));
        let lo = out.last().map_or(0, |p| frame(p.end_s));
        let hi = segments.get(i + 1).map_or(n, |next| frame(next.start_s));
        let inside = level_of(a, b);
        let edge_level = |outside: Option<f64>| match (inside, outside) {
            (Some(i), Some(o)) => 0.5 * (i + o),
            _ => threshold,
        };
        let before = level_of(a.saturating_sub(2 * reach).max(lo), a.saturating_sub(reach));
        let after = level_of(b + reach, (b + 2 * reach).min(hi));
        let start = nearest(a, edge_level(before), true, lo, hi).unwrap_or(a);
        let end = nearest(b, edge_level(after), false, start + 1, hi).unwrap_or(b);
        let long_enough = end > start && (end - start) as f64 >= min_len_s * fps;
        let (start, end) = if long_enough { (start, end) } else { (a, b) };
        let vals: Vec<f64> = frame_p[start..end]
            .iter()
            .copied()
            .filter(|p| p.is_finite())
            .collect();
        out.push(Segment {
            start_s: start as f64 / fps,
            end_s: end as f64 / fps,
            confidence: vals.iter().sum::<f64>() / vals.len().max(1) as f64,
        });
    }
    out
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
    SegmentMatch::of_pairs(found, truth, &matched_pairs(found, truth, min_iou))
}

/// The pairs `(found index, truth index)` that [`match_segments`] counts,
/// in the order it takes them (best IoU first).
pub fn matched_pairs(
    found: &[(f64, f64)],
    truth: &[(f64, f64)],
    min_iou: f64,
) -> Vec<(usize, usize)> {
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
    let mut out = Vec::new();
    for (_, i, j) in pairs {
        if !used_f[i] && !used_t[j] {
            used_f[i] = true;
            used_t[j] = true;
            out.push((i, j));
        }
    }
    out
}

impl SegmentMatch {
    /// [`match_segments`]' result from its [`matched_pairs`], for a caller
    /// that needs the pairs too.
    pub fn of_pairs(
        found: &[(f64, f64)],
        truth: &[(f64, f64)],
        pairs: &[(usize, usize)],
    ) -> SegmentMatch {
        let onset_errors_s = pairs
            .iter()
            .map(|&(i, j)| (found[i].0 - truth[j].0).abs())
            .collect();
        SegmentMatch::from_counts(found.len(), truth.len(), onset_errors_s)
    }

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

    /// A segment over `[a, b)` seconds, confidence 0.
    fn seg(a: f64, b: f64) -> Segment {
        Segment {
            start_s: a,
            end_s: b,
            confidence: 0.0,
        }
    }

    fn ends(segments: &[Segment]) -> Vec<(f64, f64)> {
        segments.iter().map(|s| (s.start_s, s.end_s)).collect()
    }

    #[test]
    fn an_unscored_stretch_says_which_of_the_two_reasons_it_has() {
        let u = |usable_s| Unscored {
            start_s: 12.0,
            end_s: 19.0,
            usable_s,
            needed_s: 7.0,
        };
        assert_eq!(
            u(3.24).reason(10.0),
            "not enough gaze: 3.2 s usable, 7.0 s needed within one 10 s window"
        );
        assert_eq!(
            u(7.0).reason(10.0),
            "no score: gaze gaps leave no whole 10 s window with gaze in 7.0 s of it"
        );
    }

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

    #[test]
    fn edges_move_to_the_window_means_crossings_within_reach() {
        // fps 1: frames are seconds. The window mean reads 0.8 over
        // [10, 25) and [50, 56), 0.2 elsewhere, nothing over [70, 80).
        let mut mean: Vec<f64> = (0..80)
            .map(|k| {
                if (10..25).contains(&k) || (50..56).contains(&k) {
                    0.8
                } else {
                    0.2
                }
            })
            .collect();
        for v in &mut mean[70..] {
            *v = f64::NAN;
        }
        let frame_p: Vec<f64> = (0..80).map(|k| k as f64 / 100.0).collect();
        let got = refine_edges(
            &[seg(13.0, 28.0), seg(40.0, 48.0), seg(51.0, 58.0)],
            &mean,
            &frame_p,
            1.0,
            0.5,
            5,
            5.0,
        );
        // The first moves 3 s back and 3 s back; the second has no crossing
        // within 5 s of either end and stays; the third would move to
        // [50, 56) (6 s): start 1 s back, end 2 s back.
        assert_eq!(ends(&got), [(10.0, 25.0), (40.0, 48.0), (50.0, 56.0)]);
        // Confidence: frame_p's mean over [10, 25) = (0.10 + 0.24) / 2.
        assert!(
            (got[0].confidence - 0.17).abs() < 1e-12,
            "{}",
            got[0].confidence
        );
        // Out of reach (2 s), the first keeps its ends.
        let got = refine_edges(&[seg(13.0, 28.0)], &mean, &frame_p, 1.0, 0.5, 2, 5.0);
        assert_eq!((got[0].start_s, got[0].end_s), (13.0, 28.0));
        // Moves that would leave under 8 s keep the segment's own ends.
        let got = refine_edges(&[seg(51.0, 58.0)], &mean, &frame_p, 1.0, 0.5, 5, 8.0);
        assert_eq!((got[0].start_s, got[0].end_s), (51.0, 58.0));
        // A start never moves before the previous segment's end, an end
        // never past the next one's start: with no level outside either
        // (neighbours), both cross at 0.5; the rise at 50 is behind the
        // first segment's end at 52, the fall at 56 beyond the second's
        // start at 53.
        let got = refine_edges(
            &[seg(44.0, 52.0), seg(53.0, 60.0)],
            &mean,
            &frame_p,
            1.0,
            0.5,
            5,
            2.0,
        );
        assert_eq!((got[0].start_s, got[0].end_s), (44.0, 52.0));
        assert_eq!((got[1].start_s, got[1].end_s), (53.0, 60.0));
        // A fall into no value counts: the mean stops at 70.
        for v in &mut mean[60..70] {
            *v = 0.9;
        }
        let got = refine_edges(&[seg(62.0, 68.0)], &mean, &frame_p, 1.0, 0.5, 5, 5.0);
        assert_eq!((got[0].start_s, got[0].end_s), (60.0, 70.0));
    }

    #[test]
    fn a_short_hmm_segment_is_moved_to_its_edges_before_the_length_rule() {
        // fps 1, windows of 10 frames. The window mean of a 20-s answer
        // among talk: 0.1, a ramp up over [35, 45) by 0.08 a frame, 0.9
        // over [45, 55), a ramp down over [55, 65), 0.1 again; and a
        // blip over [99, 103) at 0.6. The HMM's posterior passes one
        // half over [48, 51) only (3 s), and over [100, 102).
        let mean: Vec<f64> = (0..120)
            .map(|k| match k {
                35..=44 => 0.1 + 0.08 * (k - 35) as f64,
                45..=54 => 0.9,
                55..=64 => 0.9 - 0.08 * (k - 55) as f64,
                99..=102 => 0.6,
                _ => 0.1,
            })
            .collect();
        let frame_p: Vec<f64> = (0..120)
            .map(|k| {
                if (48..51).contains(&k) || (100..102).contains(&k) {
                    0.55
                } else {
                    0.2
                }
            })
            .collect();
        // Cut with the length rule first, nothing is left.
        assert!(segments(&frame_p, 1.0, 0.5, MIN_SEGMENT_S, MAX_GAP_S).is_empty());
        let got = edge_segments(&mean, &frame_p, 1.0, 0.5, 10);
        // Too few frames inside [48, 51) for a level (half a window), so
        // the edges cross 0.5: rising at 40 (0.1 + 0.08 x 5), falling
        // below it at 61 (0.9 - 0.08 x 6 = 0.42). The blip moves to
        // [99, 103), 4 s, and is dropped.
        assert_eq!(ends(&got), [(40.0, 61.0)]);
        // Confidence: the posterior's mean over [40, 61): 3 frames at
        // 0.55, 18 at 0.2.
        let want = (3.0 * 0.55 + 18.0 * 0.2) / 21.0;
        assert!(
            (got[0].confidence - want).abs() < 1e-12,
            "{}",
            got[0].confidence
        );
    }

    #[test]
    fn a_window_of_talk_inside_a_segment_cuts_it_and_a_glance_does_not() {
        // fps 1, windows of 10 frames. One segment over [0, 70): reading
        // at 0.9 with 15 s of talk at 0.1 over [30, 45) and a 5-s glance
        // at 0.2 over [55, 60); talk at 0.1 after it, over [70, 100).
        let mean: Vec<f64> = (0..100)
            .map(|k| match k {
                30..=44 | 70.. => 0.1,
                55..=59 => 0.2,
                _ => 0.9,
            })
            .collect();
        let frame_p: Vec<f64> = (0..100).map(|k| k as f64 / 100.0).collect();
        let got = split_at_dips(&[seg(0.0, 70.0)], &mean, &frame_p, 1.0, 0.5, 10);
        // Inside: 50 frames at 0.9, 15 at 0.1, 5 at 0.2: median 0.9;
        // outside 0.1; level 0.5. The talk (15 frames) cuts, the glance
        // (5) does not.
        assert_eq!(ends(&got), [(0.0, 30.0), (45.0, 70.0)]);
        // Confidences: frame_p's means, (0 + 0.29) / 2 and (0.45 + 0.69) / 2.
        assert!((got[0].confidence - 0.145).abs() < 1e-12);
        assert!((got[1].confidence - 0.57).abs() < 1e-12);
        // With no frame outside every segment, the level is the threshold:
        // at 0.15 only the two talks are under it; with windows of 16
        // frames the first (15) stays inside and the last (30, at the
        // segment's end) goes.
        let got = split_at_dips(&[seg(0.0, 100.0)], &mean, &frame_p, 1.0, 0.15, 16);
        assert_eq!(ends(&got), [(0.0, 70.0)]);
    }

    #[test]
    fn an_edge_crosses_half_way_between_the_levels_not_at_one_half() {
        // fps 1. Talk at 0.1, a ramp over [20, 30) up to reading at 0.5
        // (windows of a small text), back to 0.1 at 60: the change sits in
        // the ramp's middle, at 25, where the mean is 0.3.
        let mean: Vec<f64> = (0..90)
            .map(|k| match k {
                0..=19 => 0.1,
                20..=29 => 0.1 + 0.04 * (k - 20) as f64,
                30..=59 => 0.5,
                _ => 0.1,
            })
            .collect();
        let frame_p = vec![0.5; 90];
        let got = refine_edges(&[seg(28.0, 55.0)], &mean, &frame_p, 1.0, 0.5, 10, 5.0);
        // Inside 0.5, outside 0.1: level 0.3, first reached at 25 (0.1 +
        // 0.04 x 5); the end falls below 0.3 at 60. One half would have
        // put the start at 30, the end at 60 too.
        assert_eq!((got[0].start_s, got[0].end_s), (25.0, 60.0));
    }
}
