//! Distributional fidelity: the source pool of each class against the union
//! of that class's generated sessions.
//!
//! Segmenting: the source pool is the concatenation of several recordings;
//! its metrics are computed within each recording (the `source` column), so
//! the artificial jump where two recordings meet is not counted as a speed or
//! a saccade. Each generated session is one segment and is measured as it is,
//! including any jump it inherited from crossing a source border or wrapping
//! around the pool end: those jumps are in the generated data and would be
//! rendered.

use crate::dataset::Dataset;
use crate::ks::KsResult;
use crate::metrics::{Event, EventKind, IvtThresholds, MetricSamples};
use crate::stats::{linear_fit, median, quantile_sorted, sorted};
use eyereplay_core::GazeClass;
use serde::Serialize;

/// The paper's three compared metrics.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Metric {
    Speed,
    FixationDuration,
    SaccadeAmplitude,
}

impl Metric {
    pub const ALL: [Metric; 3] = [
        Metric::Speed,
        Metric::FixationDuration,
        Metric::SaccadeAmplitude,
    ];

    /// Key in metrics.json.
    pub fn key(self) -> &'static str {
        match self {
            Metric::Speed => "speed",
            Metric::FixationDuration => "fixation_duration",
            Metric::SaccadeAmplitude => "saccade_amplitude",
        }
    }

    pub fn title(self) -> &'static str {
        match self {
            Metric::Speed => "Speed",
            Metric::FixationDuration => "Fixation duration",
            Metric::SaccadeAmplitude => "Saccade amplitude",
        }
    }

    pub fn unit(self) -> &'static str {
        match self {
            Metric::Speed => "px/frame",
            Metric::FixationDuration => "frames",
            Metric::SaccadeAmplitude => "px",
        }
    }

    pub fn samples(self, m: &MetricSamples) -> &[f64] {
        match self {
            Metric::Speed => &m.speed_px_per_frame,
            Metric::FixationDuration => &m.fixation_duration_frames,
            Metric::SaccadeAmplitude => &m.saccade_amplitude_px,
        }
    }

    /// The paper's KS D for this metric and class (Table 2), for reference.
    pub fn paper_d(self, class: GazeClass) -> f64 {
        match (self, class) {
            (Metric::Speed, GazeClass::Reading) => 0.083,
            (Metric::Speed, GazeClass::Conversation) => 0.034,
            (Metric::FixationDuration, GazeClass::Reading) => 0.118,
            (Metric::FixationDuration, GazeClass::Conversation) => 0.006,
            (Metric::SaccadeAmplitude, GazeClass::Reading) => 0.136,
            (Metric::SaccadeAmplitude, GazeClass::Conversation) => 0.079,
        }
    }
}

/// Evaluation parameters.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct EvalConfig {
    pub thresholds: IvtThresholds,
    /// Length of the time-series windows shown, seconds (paper: 30).
    pub window_s: f64,
    /// Number of quantiles in each Q-Q panel.
    pub qq_points: usize,
    /// A KS D at or below this passes (the paper's worst D was 0.136).
    pub d_max: f64,
    /// Canvas px per degree of visual angle, when the viewing geometry is
    /// known; adds amplitudes in degrees.
    pub px_per_deg: Option<f64>,
}

impl Default for EvalConfig {
    fn default() -> Self {
        EvalConfig {
            thresholds: IvtThresholds::default(),
            window_s: 30.0,
            qq_points: 100,
            d_max: 0.15,
            px_per_deg: None,
        }
    }
}

/// One metric of one class, source against generated.
#[derive(Clone, Debug, PartialEq)]
pub struct MetricComparison {
    pub metric: Metric,
    /// `None` when either side has no samples (e.g. no saccades at all).
    pub ks: Option<KsResult>,
    pub n_source: usize,
    pub n_generated: usize,
    /// (source quantile, generated quantile) pairs.
    pub qq: Vec<(f64, f64)>,
    pub median_source: Option<f64>,
    pub median_generated: Option<f64>,
}

/// Rates and shapes beyond the paper, for one side of one class.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Extras {
    pub n_frames: usize,
    pub n_segments: usize,
    pub duration_s: f64,
    pub n_fixations: usize,
    pub n_saccades: usize,
    pub fixation_rate_per_s: f64,
    pub saccade_rate_per_s: f64,
    /// Held-position runs (forward-filled blinks) per minute.
    pub blink_rate_per_min: f64,
    /// Blinks per minute from the sessions' `blink` column, when they have
    /// one (generated side only: the pool has no such column).
    pub blink_column_rate_per_min: Option<f64>,
    pub fixation_duration_median_ms: Option<f64>,
    pub saccade_amplitude_median_px: Option<f64>,
    pub saccade_amplitude_median_deg: Option<f64>,
    pub fixation_dispersion_median_px: Option<f64>,
    pub speed_median_px_per_s: Option<f64>,
    /// Main sequence fit `log10(peak speed px/s) = exponent *
    /// log10(amplitude px) + log10(coefficient)`.
    pub main_sequence_exponent: Option<f64>,
    pub main_sequence_coefficient: Option<f64>,
}

pub fn extras(m: &MetricSamples, fps: f64, px_per_deg: Option<f64>) -> Extras {
    let dur = m.duration_s(fps);
    let amp_med = median(&m.saccade_amplitude_px);
    let (lx, ly): (Vec<f64>, Vec<f64>) = m
        .saccade_amplitude_px
        .iter()
        .zip(&m.saccade_peak_speed_px_per_frame)
        .filter(|(a, p)| **a > 0.0 && **p > 0.0)
        .map(|(a, p)| (a.log10(), (p * fps).log10()))
        .unzip();
    let fit = linear_fit(&lx, &ly);
    Extras {
        n_frames: m.n_frames,
        n_segments: m.n_segments,
        duration_s: dur,
        n_fixations: m.fixation_duration_frames.len(),
        n_saccades: m.saccade_amplitude_px.len(),
        fixation_rate_per_s: m.fixation_duration_frames.len() as f64 / dur,
        saccade_rate_per_s: m.saccade_amplitude_px.len() as f64 / dur,
        blink_rate_per_min: m.n_blinks as f64 / dur * 60.0,
        blink_column_rate_per_min: None,
        fixation_duration_median_ms: median(&m.fixation_duration_frames).map(|f| f * 1000.0 / fps),
        saccade_amplitude_median_px: amp_med,
        saccade_amplitude_median_deg: px_per_deg.and_then(|k| amp_med.map(|a| a / k)),
        fixation_dispersion_median_px: median(&m.fixation_dispersion_px),
        speed_median_px_per_s: median(&m.speed_px_per_frame).map(|s| s * fps),
        main_sequence_exponent: fit.map(|f| f.0),
        main_sequence_coefficient: fit.map(|f| 10f64.powf(f.1)),
    }
}

/// Everything measured for one class.
#[derive(Clone, Debug)]
pub struct ClassEvaluation {
    pub class: GazeClass,
    pub n_sessions: usize,
    pub source: MetricSamples,
    pub generated: MetricSamples,
    pub comparisons: Vec<MetricComparison>,
    pub extras_source: Extras,
    pub extras_generated: Extras,
    /// First `window_s` seconds of the source pool's first segment.
    pub window_source: Vec<[f64; 2]>,
    /// First `window_s` seconds of the first generated session.
    pub window_generated: Vec<[f64; 2]>,
    pub window_generated_file: String,
    /// Events of each generated session: (relative session file, events).
    pub events: Vec<(String, Vec<Event>)>,
}

/// Compares two metric samples.
pub fn compare_metric(
    metric: Metric,
    src: &[f64],
    gen: &[f64],
    qq_points: usize,
) -> MetricComparison {
    let (ss, gs) = (sorted(src), sorted(gen));
    let ks = (!ss.is_empty() && !gs.is_empty()).then(|| crate::ks::ks_2samp_sorted(&ss, &gs));
    let qq = if ss.is_empty() || gs.is_empty() {
        Vec::new()
    } else {
        (0..qq_points)
            .map(|i| {
                let q = (i as f64 + 0.5) / qq_points as f64;
                (
                    quantile_sorted(&ss, q).unwrap(),
                    quantile_sorted(&gs, q).unwrap(),
                )
            })
            .collect()
    };
    MetricComparison {
        metric,
        ks,
        n_source: ss.len(),
        n_generated: gs.len(),
        qq,
        median_source: quantile_sorted(&ss, 0.5),
        median_generated: quantile_sorted(&gs, 0.5),
    }
}

/// Measures one class of a dataset.
pub fn evaluate_class(ds: &Dataset, class_index: usize, cfg: &EvalConfig) -> ClassEvaluation {
    let cd = &ds.classes[class_index];
    let thr = &cfg.thresholds;
    let mut source = MetricSamples::default();
    for seg in &cd.pool {
        source.add_segment(&seg.points, thr);
    }
    let mut generated = MetricSamples::default();
    let mut events = Vec::with_capacity(cd.sessions.len());
    let mut column_blinks: Option<usize> = None;
    for s in &cd.sessions {
        let mut ev = generated.add_segment(&s.points, thr);
        if let Some(b) = &s.blinks {
            // The source's own blink marks replace the held-position proxy
            // in the events export.
            ev.retain(|e| e.kind != EventKind::Blink);
            let flags: Vec<f64> = b.iter().map(|&x| if x { 1.0 } else { 0.0 }).collect();
            let runs = crate::metrics::runs(&flags, |v| v > 0.5);
            *column_blinks.get_or_insert(0) += runs.len();
            ev.extend(runs.into_iter().map(|(start, len)| Event {
                kind: EventKind::Blink,
                onset_frame: start,
                offset_frame: start + len - 1,
                amplitude_px: 0.0,
                peak_speed_px_per_frame: 0.0,
                dispersion_px: 0.0,
            }));
            ev.sort_by_key(|e| (e.onset_frame, e.kind));
        }
        events.push((s.file.clone(), ev));
    }
    let comparisons = Metric::ALL
        .iter()
        .map(|&m| compare_metric(m, m.samples(&source), m.samples(&generated), cfg.qq_points))
        .collect();
    // At most a session long: a longer window showed more of the pool
    // than of the session beside it, on time axes that did not match.
    let win = ((cfg.window_s * ds.fps).round() as usize)
        .min(ds.session_frames)
        .max(2);
    let first = &cd.pool[0].points;
    // The middle session: it is cut from the middle of the pool, where the
    // first is cut from its start and would show the pool's first seconds
    // again beside them.
    let sess = &cd.sessions[cd.sessions.len() / 2];
    ClassEvaluation {
        class: cd.class,
        n_sessions: cd.sessions.len(),
        extras_source: extras(&source, ds.fps, cfg.px_per_deg),
        extras_generated: Extras {
            blink_column_rate_per_min: column_blinks
                .map(|n| n as f64 / generated.duration_s(ds.fps) * 60.0),
            ..extras(&generated, ds.fps, cfg.px_per_deg)
        },
        source,
        generated,
        comparisons,
        window_source: first[..win.min(first.len())].to_vec(),
        window_generated: sess.points[..win.min(sess.points.len())].to_vec(),
        window_generated_file: sess.file.clone(),
        events,
    }
}
