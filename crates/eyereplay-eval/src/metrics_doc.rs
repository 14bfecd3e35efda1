//! `report/metrics.json` as typed structs. Serialized through serde into the
//! [`Json`] tree, whose objects keep their keys sorted and whose floats have
//! one fixed format, so the file is byte-identical on a rerun whatever
//! features other crates switch on in `serde_json`.
//!
//! Keys include `distribution.<class>.<metric>.{ks_d,ks_p,n_source,n_generated}`,
//! `visual.{x,y}.{r,amplitude_ratio,gain}` and `visual.error.{mean,median,p95}`.

use crate::distribution::{ClassEvaluation, Extras, MetricComparison};
use crate::evaluation::{Evaluation, HeadYawReadBack, VisualSection};
use crate::json::Json;
use crate::visual::{
    AxisFidelity, ErrorStats, VisualFidelity, TARGET_AMPLITUDE_RATIO, TARGET_R_MIN,
};
use serde::Serialize;
use std::collections::BTreeMap;

#[derive(Serialize)]
struct MetricsDoc<'a> {
    tool_version: &'static str,
    dataset: DatasetPart,
    parameters: Parameters,
    distribution: BTreeMap<&'static str, BTreeMap<&'static str, Distribution>>,
    extras: BTreeMap<&'static str, ExtrasPair>,
    events: Events,
    visual: Visual<'a>,
    /// Behaviour models against real recordings, per class.
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    behaviour: BTreeMap<&'static str, &'a [crate::behaviour::BehaviourRow]>,
}

#[derive(Serialize)]
struct DatasetPart {
    fps: f64,
    canvas: Canvas,
    session_frames: usize,
    classes: BTreeMap<&'static str, ClassSizes>,
}

#[derive(Serialize)]
struct Canvas {
    width_px: u32,
    height_px: u32,
}

#[derive(Serialize)]
struct ClassSizes {
    n_sessions: usize,
    pool_frames: usize,
    pool_segments: usize,
}

#[derive(Serialize)]
struct Parameters {
    fixation_below_px_per_frame: f64,
    saccade_above_px_per_frame: f64,
    blink_hold_min_frames: usize,
    window_s: f64,
    qq_points: usize,
    ks_d_max: f64,
    px_per_deg: Option<f64>,
    ks_test: &'static str,
    segments: &'static str,
}

#[derive(Serialize)]
struct Distribution {
    ks_d: Option<f64>,
    ks_p: Option<f64>,
    ks_method: Option<String>,
    n_source: usize,
    n_generated: usize,
    median_source: Option<f64>,
    median_generated: Option<f64>,
    unit: &'static str,
    paper_ks_d: f64,
    passes_d_max: Option<bool>,
}

#[derive(Serialize)]
struct ExtrasPair {
    source: ExtrasPart,
    generated: ExtrasPart,
}

#[derive(Serialize)]
struct ExtrasPart {
    n_frames: usize,
    n_segments: usize,
    duration_s: f64,
    n_fixations: usize,
    n_saccades: usize,
    fixation_rate_per_s: f64,
    saccade_rate_per_s: f64,
    blink_rate_per_min: f64,
    blink_column_rate_per_min: Option<f64>,
    fixation_duration_median_ms: Option<f64>,
    saccade_amplitude_median_px: Option<f64>,
    saccade_amplitude_median_deg: Option<f64>,
    fixation_dispersion_median_px: Option<f64>,
    speed_median_px_per_s: Option<f64>,
    main_sequence: MainSequence,
}

#[derive(Serialize)]
struct MainSequence {
    exponent: Option<f64>,
    coefficient_px_per_s: Option<f64>,
}

#[derive(Serialize)]
struct Events {
    layout: &'static str,
    time_unit: &'static str,
    dir: &'static str,
}

#[derive(Serialize)]
struct Visual<'a> {
    target: Target,
    computed: bool,
    #[serde(skip_serializing_if = "Option::is_none")]
    reason: Option<&'a str>,
    #[serde(skip_serializing_if = "Option::is_none")]
    video: Option<&'a str>,
    #[serde(skip_serializing_if = "Option::is_none")]
    eye_locator: Option<&'a str>,
    #[serde(skip_serializing_if = "Option::is_none")]
    n_frames: Option<usize>,
    x: Axis,
    y: Axis,
    error: Error,
    #[serde(skip_serializing_if = "Option::is_none")]
    input: Option<Input>,
    #[serde(skip_serializing_if = "Option::is_none")]
    meets_targets: Option<bool>,
    #[serde(skip_serializing_if = "Option::is_none")]
    detection_rate: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    render_truth: Option<RenderTruth<'a>>,
    /// `evaluate --read-back-all`: every session.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    sessions: Vec<SessionRow<'a>>,
}

#[derive(Serialize)]
struct SessionRow<'a> {
    session: &'a str,
    class: &'a str,
    n_frames: usize,
    detection_rate: f64,
    x: Axis,
    y: Axis,
    error: Error,
    /// Full-face sessions only.
    #[serde(skip_serializing_if = "Option::is_none")]
    head_yaw: Option<HeadYawReadBack>,
    /// Sessions read by the face detector's pipeline with a truth CSV.
    #[serde(skip_serializing_if = "Option::is_none")]
    budget: Option<crate::ReadBackBudget>,
}

#[derive(Serialize)]
struct Target {
    r_min: f64,
    amplitude_ratio_min: f64,
    amplitude_ratio_max: f64,
}

/// One axis; the detail fields only when a video was compared.
#[derive(Serialize)]
struct Axis {
    r: Option<f64>,
    amplitude_ratio: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    gain: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    std_source: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    std_rendered: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    meets_targets: Option<bool>,
}

#[derive(Serialize)]
struct Error {
    mean: Option<f64>,
    median: Option<f64>,
    p95: Option<f64>,
}

#[derive(Serialize)]
struct Input {
    range_x_px: f64,
    range_y_px: f64,
    range_x_pct_canvas: f64,
    range_y_pct_canvas: f64,
    p5_p95_x_px: f64,
    p5_p95_y_px: f64,
}

#[derive(Serialize)]
struct RenderTruth<'a> {
    file: &'a str,
    n_frames: usize,
    x: Axis,
    y: Axis,
    error: Error,
}

impl Axis {
    fn none() -> Self {
        Axis {
            r: None,
            amplitude_ratio: None,
            gain: None,
            std_source: None,
            std_rendered: None,
            meets_targets: None,
        }
    }
    fn brief(a: &AxisFidelity) -> Self {
        Axis {
            r: a.r,
            amplitude_ratio: a.amplitude_ratio,
            gain: a.gain,
            ..Axis::none()
        }
    }
    fn full(a: &AxisFidelity) -> Self {
        Axis {
            std_source: Some(a.std_source),
            std_rendered: Some(a.std_rendered),
            meets_targets: Some(a.meets_targets()),
            ..Axis::brief(a)
        }
    }
}

impl Error {
    fn of(e: &ErrorStats) -> Self {
        Error {
            mean: Some(e.mean),
            median: Some(e.median),
            p95: Some(e.p95),
        }
    }
}

impl ExtrasPart {
    fn of(e: &Extras) -> Self {
        ExtrasPart {
            n_frames: e.n_frames,
            n_segments: e.n_segments,
            duration_s: e.duration_s,
            n_fixations: e.n_fixations,
            n_saccades: e.n_saccades,
            fixation_rate_per_s: e.fixation_rate_per_s,
            saccade_rate_per_s: e.saccade_rate_per_s,
            blink_rate_per_min: e.blink_rate_per_min,
            blink_column_rate_per_min: e.blink_column_rate_per_min,
            fixation_duration_median_ms: e.fixation_duration_median_ms,
            saccade_amplitude_median_px: e.saccade_amplitude_median_px,
            saccade_amplitude_median_deg: e.saccade_amplitude_median_deg,
            fixation_dispersion_median_px: e.fixation_dispersion_median_px,
            speed_median_px_per_s: e.speed_median_px_per_s,
            main_sequence: MainSequence {
                exponent: e.main_sequence_exponent,
                coefficient_px_per_s: e.main_sequence_coefficient,
            },
        }
    }
}

fn distribution(ce: &ClassEvaluation, cmp: &MetricComparison, d_max: f64) -> Distribution {
    Distribution {
        ks_d: cmp.ks.map(|k| k.d),
        ks_p: cmp.ks.map(|k| k.p),
        ks_method: cmp.ks.map(|k| format!("{:?}", k.method).to_lowercase()),
        n_source: cmp.n_source,
        n_generated: cmp.n_generated,
        median_source: cmp.median_source,
        median_generated: cmp.median_generated,
        unit: cmp.metric.unit(),
        paper_ks_d: cmp.metric.paper_d(ce.class),
        passes_d_max: cmp.ks.map(|k| k.d <= d_max),
    }
}

fn visual(ev: &Evaluation) -> Visual<'_> {
    let mut v = Visual {
        target: Target {
            r_min: TARGET_R_MIN,
            amplitude_ratio_min: TARGET_AMPLITUDE_RATIO.0,
            amplitude_ratio_max: TARGET_AMPLITUDE_RATIO.1,
        },
        computed: false,
        reason: None,
        video: None,
        eye_locator: None,
        n_frames: None,
        x: Axis::none(),
        y: Axis::none(),
        error: Error {
            mean: None,
            median: None,
            p95: None,
        },
        input: None,
        meets_targets: None,
        detection_rate: None,
        render_truth: ev
            .render_truth
            .as_ref()
            .map(|(file, t)| render_truth(file, t)),
        sessions: ev
            .sessions_read_back
            .iter()
            .map(|r| SessionRow {
                session: &r.session,
                class: &r.class,
                n_frames: r.fidelity.n_frames,
                detection_rate: r.detection_rate,
                x: Axis::brief(&r.fidelity.x),
                y: Axis::brief(&r.fidelity.y),
                error: Error::of(&r.fidelity.error),
                head_yaw: r.head_yaw,
                budget: r.budget,
            })
            .collect(),
    };
    match &ev.visual {
        VisualSection::NotComputed { reason } => v.reason = Some(reason),
        VisualSection::Computed(run) => {
            let f = &run.fidelity;
            v.computed = true;
            v.video = Some(&run.video);
            v.eye_locator = Some(&run.eye_locator);
            v.n_frames = Some(f.n_frames);
            v.x = Axis::full(&f.x);
            v.y = Axis::full(&f.y);
            v.error = Error::of(&f.error);
            v.input = f.input.as_ref().map(|i| Input {
                range_x_px: i.range_px[0],
                range_y_px: i.range_px[1],
                range_x_pct_canvas: i.range_pct_canvas[0],
                range_y_pct_canvas: i.range_pct_canvas[1],
                p5_p95_x_px: i.p5_p95_px[0],
                p5_p95_y_px: i.p5_p95_px[1],
            });
            v.meets_targets = Some(f.meets_targets());
            v.detection_rate = Some(run.detection_rate);
        }
    }
    v
}

fn render_truth<'a>(file: &'a str, t: &VisualFidelity) -> RenderTruth<'a> {
    RenderTruth {
        file,
        n_frames: t.n_frames,
        x: Axis::brief(&t.x),
        y: Axis::brief(&t.y),
        error: Error::of(&t.error),
    }
}

/// The metrics.json tree of an evaluation.
pub fn metrics_json(ev: &Evaluation) -> Json {
    let c = &ev.config;
    let mut classes = BTreeMap::new();
    let mut dist = BTreeMap::new();
    let mut extras = BTreeMap::new();
    for (i, ce) in ev.classes.iter().enumerate() {
        let cls = ce.class.name();
        classes.insert(
            cls,
            ClassSizes {
                n_sessions: ce.n_sessions,
                pool_frames: ev.pool_frames[i],
                pool_segments: ev.pool_segments[i],
            },
        );
        let per_metric = ce
            .comparisons
            .iter()
            .map(|m| (m.metric.key(), distribution(ce, m, c.d_max)))
            .collect();
        dist.insert(cls, per_metric);
        extras.insert(
            cls,
            ExtrasPair {
                source: ExtrasPart::of(&ce.extras_source),
                generated: ExtrasPart::of(&ce.extras_generated),
            },
        );
    }
    let doc = MetricsDoc {
        tool_version: eyereplay_core::TOOL_VERSION,
        dataset: DatasetPart {
            fps: ev.fps,
            canvas: Canvas {
                width_px: ev.canvas.width_px,
                height_px: ev.canvas.height_px,
            },
            session_frames: ev.session_frames,
            classes,
        },
        parameters: Parameters {
            fixation_below_px_per_frame: c.thresholds.fixation_below_px_per_frame,
            saccade_above_px_per_frame: c.thresholds.saccade_above_px_per_frame,
            blink_hold_min_frames: c.thresholds.hold_min_frames,
            window_s: c.window_s,
            qq_points: c.qq_points,
            ks_d_max: c.d_max,
            px_per_deg: c.px_per_deg,
            ks_test: "two-sided two-sample KS as scipy.stats.ks_2samp(method='auto'): exact p if max(n1, n2) <= 10000, else asymptotic",
            segments: "source pool metrics are computed within each source recording (column 'source'); each generated session is one segment",
        },
        distribution: dist,
        extras,
        events: Events {
            layout: "name,onset,offset",
            time_unit: "ms",
            dir: "report/events",
        },
        visual: visual(ev),
        behaviour: ev
            .behaviour
            .iter()
            .map(|b| (b.class.name(), b.rows.as_slice()))
            .collect(),
    };
    Json::from(serde_json::to_value(&doc).expect("metrics serialize: string keys only"))
}
