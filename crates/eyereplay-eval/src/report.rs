//! The evaluation of a whole dataset folder and its outputs:
//! `report/metrics.json` (deterministic), `report/index.html`
//! (self-contained, figures inlined as base64 PNG), `report/figures/*.{png,svg}`
//! and `report/events/<class>/<stem>.csv` (pymovements' events layout).

use crate::distribution::Metric;
use crate::metrics::events_csv;
use crate::plot::{main_sequence_figure, qq_figure, visual_figure, windows_figure, Figure};
use crate::visual::{TARGET_AMPLITUDE_RATIO, TARGET_R_MIN};
use crate::EvalError;
use base64::Engine;
use eyereplay_core::atomic_write;
use std::fmt::Write;
use std::path::{Path, PathBuf};

pub use crate::evaluation::{
    evaluate_dataset, evaluate_loaded, Evaluation, HeadYawReadBack, SessionReadBack, VisualRun,
    VisualSection, HEAD_YAW_READ_BACK_S, TARGET_HEAD_YAW_R_MIN, VISUAL_NOT_WIRED,
};
pub use crate::metrics_doc::metrics_json;

/// All figures of an evaluation.
pub fn figures(ev: &Evaluation) -> Result<Vec<Figure>, EvalError> {
    let mut f = vec![
        qq_figure(&ev.classes, ev.config.d_max)?,
        windows_figure(&ev.classes, ev.fps)?,
        main_sequence_figure(&ev.classes, ev.fps)?,
    ];
    if !ev.behaviour.is_empty() {
        // The same figures, real recordings as "source" and the behaviour
        // model as "generated".
        let checks: Vec<_> = ev.behaviour.iter().map(|b| b.figures.clone()).collect();
        let mut qq = qq_figure(&checks, f64::INFINITY)?;
        qq.name = "behaviour_qq".into();
        let mut strip = windows_figure(&checks, ev.fps)?;
        strip.name = "behaviour_windows".into();
        f.push(qq);
        f.push(strip);
    }
    if let VisualSection::Computed(run) = &ev.visual {
        f.push(visual_figure(
            &run.fidelity,
            &run.source_n,
            &run.rendered_n,
            ev.fps,
        )?);
    }
    Ok(f)
}

/// Text escaped for HTML element content and double-quoted attribute
/// values (`&`, `<`, `>`, `"`).
pub fn html_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

fn f3(v: Option<f64>) -> String {
    v.map_or("n/a".into(), |v| format!("{v:.3}"))
}

fn fp(p: f64) -> String {
    if p == 0.0 {
        "0 (below double precision)".into()
    } else if p >= 1e-3 {
        format!("{p:.4}")
    } else {
        format!("{p:.3e}")
    }
}

fn img(f: &Figure, alt: &str) -> String {
    format!(
        "<figure><img alt=\"{}\" width=\"{}\" src=\"data:image/png;base64,{}\"><figcaption>{} \
(<a href=\"figures/{}.svg\">SVG</a>, <a href=\"figures/{}.png\">PNG</a>)</figcaption></figure>\n",
        html_escape(alt),
        f.size.0,
        base64::engine::general_purpose::STANDARD.encode(&f.png),
        alt,
        f.name,
        f.name
    )
}

/// Whether a read-back r meets its target `min` (r, or head yaw's r).
fn r_meets(r: Option<f64>, min: f64) -> bool {
    matches!(r, Some(r) if r >= min)
}

/// Whether an amplitude ratio lies in [`TARGET_AMPLITUDE_RATIO`].
fn ratio_meets(ratio: Option<f64>) -> bool {
    let (lo, hi) = TARGET_AMPLITUDE_RATIO;
    matches!(ratio, Some(x) if (lo..=hi).contains(&x))
}

/// `v` to three decimals, marked as failed where it misses (`ok` false).
fn mark(v: Option<f64>, ok: bool) -> String {
    match v {
        Some(x) if !ok => format!("<span class=\"fail\">{x:.3}</span>"),
        _ => f3(v),
    }
}

fn verdict(ok: bool) -> &'static str {
    if ok {
        "<span class=\"pass\">pass</span>"
    } else {
        "<span class=\"fail\">fail</span>"
    }
}

/// The self-contained HTML report.
/// A warning when the classes come from different kinds of recording: a
/// classifier could then learn the recording type (landmark jitter of webcam
/// video versus a tracker's clean signal) instead of the behaviour.
fn recording_kind_note(ev: &Evaluation) -> String {
    let kinds: Vec<Vec<&String>> = ev.source_kinds.iter().map(|k| k.keys().collect()).collect();
    if kinds.len() < 2
        || kinds.iter().any(|k| k.is_empty())
        || kinds.windows(2).all(|w| w[0] == w[1])
    {
        return String::new();
    }
    let per_class: Vec<String> = ev
        .classes
        .iter()
        .zip(&kinds)
        .map(|(c, k)| {
            let names: Vec<String> = k.iter().map(|s| s.replace('_', " ")).collect();
            format!("{} from {}", c.class, names.join(" and "))
        })
        .collect();
    format!(
        "<p class=\"note\">The classes come from different kinds of recording ({}). A classifier \
trained on this data could learn the recording type instead of the behaviour. eyereplay brings \
their noise levels together (EdgeGauss smoothing of video landmarks, fixational drift in \
fixation reports); compare the fixation dispersion and the median speed under \"Beyond the paper\" \
(the Q-Q plots' linear axes leave the slow end to a corner) before relying on it, and prefer sources \
of one kind per dataset where you can.</p>\n",
        per_class.join("; ")
    )
}

/// Every check the report marks pass or fail, counted, with the failing
/// ones named: the page's summary and `evaluate`'s last line, so that a
/// reader need not find a red cell half way down the page.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Checks {
    pub total: usize,
    pub failing: Vec<String>,
}

impl Checks {
    fn check(&mut self, ok: bool, what: impl FnOnce() -> String) {
        self.total += 1;
        if !ok {
            self.failing.push(what());
        }
    }

    /// "9 of 12 checks pass"
    pub fn headline(&self) -> String {
        format!(
            "{} of {} checks pass",
            self.total - self.failing.len(),
            self.total
        )
    }

    /// The headline and, where some fail, each one: what `evaluate` and
    /// `generate` end with.
    pub fn line(&self) -> String {
        if self.failing.is_empty() {
            self.headline()
        } else {
            format!("{}; failing: {}", self.headline(), self.failing.join("; "))
        }
    }
}

/// The checks of `ev`: KS D per class and metric against the threshold;
/// each behaviour model's D against the real spread; the visual section's
/// r and amplitude ratio per axis; and each session read back, the same
/// targets and its head's yaw r.
pub fn checks(ev: &Evaluation) -> Checks {
    checks_of(
        &ev.classes,
        &ev.behaviour,
        &ev.visual,
        &ev.sessions_read_back,
        ev.config.d_max,
    )
}

fn checks_of(
    classes: &[crate::ClassEvaluation],
    behaviour: &[crate::behaviour::BehaviourCheck],
    visual: &VisualSection,
    read_back: &[SessionReadBack],
    d_max: f64,
) -> Checks {
    let mut c = Checks::default();
    for ce in classes {
        for cmp in &ce.comparisons {
            if let Some(k) = &cmp.ks {
                c.check(k.d <= d_max, || {
                    format!(
                        "{} {}: KS D {:.3} > {d_max}",
                        ce.class,
                        cmp.metric.key(),
                        k.d
                    )
                });
            }
        }
    }
    for b in behaviour {
        for r in &b.rows {
            if let Some(ok) = r.pass() {
                c.check(ok, || {
                    format!(
                        "{} {}: the behaviour model's D {} beyond the real spread {}",
                        b.class,
                        r.metric.key(),
                        f3(r.d_model),
                        f3(r.d_real)
                    )
                });
            }
        }
    }
    let (lo, hi) = TARGET_AMPLITUDE_RATIO;
    let axes = |c: &mut Checks, who: &str, f: &crate::visual::VisualFidelity| {
        for (ax, a) in [("x", &f.x), ("y", &f.y)] {
            c.check(r_meets(a.r, TARGET_R_MIN), || {
                format!("{who}: r {ax} {} < {TARGET_R_MIN}", f3(a.r))
            });
            c.check(ratio_meets(a.amplitude_ratio), || {
                format!(
                    "{who}: amplitude ratio {ax} {} outside {lo}-{hi}",
                    f3(a.amplitude_ratio)
                )
            });
        }
    };
    // The visual section's session is counted once: when the read-back
    // table holds it whole, its row stands for it.
    if let VisualSection::Computed(run) = visual {
        let stem = |p: &str| Path::new(p).with_extension("");
        let read_whole = read_back
            .iter()
            .any(|r| stem(&r.session) == stem(&run.video));
        if !read_whole {
            axes(&mut c, &format!("visual ({})", run.video), &run.fidelity);
        }
    }
    for r in read_back {
        axes(&mut c, &format!("read back {}", r.session), &r.fidelity);
        if let Some(y) = r.head_yaw {
            c.check(r_meets(y.r, TARGET_HEAD_YAW_R_MIN), || {
                format!(
                    "read back {}: head yaw r {} < {TARGET_HEAD_YAW_R_MIN}",
                    r.session,
                    f3(y.r)
                )
            });
        }
    }
    c
}

/// The summary at the top: the checks, and what each section compares.
fn summary_section(h: &mut String, ev: &Evaluation) {
    let c = checks(ev);
    let failing = if c.failing.is_empty() {
        String::new()
    } else {
        let items: String = c
            .failing
            .iter()
            .map(|f| format!("<li>{}</li>", html_escape(f)))
            .collect();
        format!("; failing:<ul>{items}</ul>")
    };
    let _ = writeln!(
        h,
        "<div class=\"summary {}\"><b>{}</b>{failing}</div>",
        if c.failing.is_empty() { "ok" } else { "bad" },
        c.headline()
    );
    h.push_str(
        "<p>What each section compares. <b>Distributional fidelity</b>: the sessions against the \
source pool they were cut from (the circular slicing of <i>A Synthetic Eye Movement Dataset for \
Script Reading Detection</i>, \"the paper\" below), so it measures what slicing, speed scaling \
and normalization keep, not realism. <b>Behaviour models against real recordings</b>: the \
generated people against the real ones in the same pool, on the scale of two real people \
against each other. <b>Visual mapping fidelity</b>: the rendered video read back by the \
extractor against the trajectory that drove it. KS D is the largest gap between two cumulative \
distributions (0: the same; a check passes at or under the threshold).</p>\n",
    );
}

pub fn report_html(ev: &Evaluation, figs: &[Figure]) -> String {
    let mut h = String::new();
    html_head(&mut h, ev);
    summary_section(&mut h, ev);
    dataset_section(&mut h, ev);
    parameters_section(&mut h, ev);
    distribution_section(&mut h, ev, figs);
    behaviour_section(&mut h, ev, figs);
    extras_section(&mut h, ev, figs);
    visual_html(&mut h, ev, figs);
    h.push_str("</body></html>\n");
    h
}

/// Document head and style.
fn html_head(h: &mut String, _ev: &Evaluation) {
    h.push_str(
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\n<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n<title>eyereplay evaluation</title>\n<style>\n\
body{font-family:system-ui,-apple-system,'Segoe UI',sans-serif;max-width:1440px;margin:2em auto;padding:0 1em;color:#222}\n\
table{border-collapse:collapse;margin:0.8em 0;display:block;max-width:100%;overflow-x:auto}td,th{border:1px solid #ccc;padding:4px 10px;text-align:right;white-space:nowrap}\n\
th{white-space:normal}td:first-child{white-space:normal;min-width:8em}.summary{border:1px solid #ccc;padding:0.6em 1em;margin:1em 0}.summary.ok{border-left:4px solid #1a7f37}.summary.bad{border-left:4px solid #c62828}.summary ul{margin:0.3em 0}\n\
th{background:#f3f3f3}td:first-child,th:first-child{text-align:left}\n\
.pass{color:#1a7f37;font-weight:600}.fail{color:#c62828;font-weight:600}\n\
figure{margin:1em 0}img{max-width:100%;height:auto;border:1px solid #ddd}figcaption{color:#555;font-size:0.9em}\n\
table.kv td{text-align:left;white-space:normal}\n\
.note{background:#fff8e1;border-left:4px solid #f0b400;padding:0.6em 1em}code{background:#f3f3f3;padding:0 3px}\n\
</style></head><body>\n<h1>eyereplay evaluation</h1>\n",
    );
}

/// Dataset: rate, canvas, session length, pools and source kinds.
fn dataset_section(h: &mut String, ev: &Evaluation) {
    h.push_str("<h2>Dataset</h2>\n<table class=\"kv\"><tr><th>property</th><th>value</th></tr>\n");
    let _ = writeln!(h, "<tr><td>frame rate</td><td>{} fps</td></tr>", ev.fps);
    let _ = writeln!(
        h,
        "<tr><td>canvas</td><td>{} x {} px</td></tr>",
        ev.canvas.width_px, ev.canvas.height_px
    );
    let _ = writeln!(
        h,
        "<tr><td>session length</td><td>{} frames ({:.1} s)</td></tr>",
        ev.session_frames,
        ev.session_frames as f64 / ev.fps
    );
    for (i, ce) in ev.classes.iter().enumerate() {
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td>{} sessions; source pool {} frames ({:.1} min) in {} source segment(s)</td></tr>",
            ce.class,
            ce.n_sessions,
            ev.pool_frames[i],
            ev.pool_frames[i] as f64 / ev.fps / 60.0,
            ev.pool_segments[i]
        );
    }
    for (i, ce) in ev.classes.iter().enumerate() {
        if let Some(kinds) = ev.source_kinds.get(i).filter(|k| !k.is_empty()) {
            let list: Vec<String> = kinds
                .iter()
                .map(|(k, n)| format!("{n} {}", k.replace('_', " ")))
                .collect();
            let _ = writeln!(
                h,
                "<tr><td>{} sources</td><td>{}</td></tr>",
                ce.class,
                list.join(", ")
            );
        }
    }
    h.push_str("</table>\n");
    h.push_str(&recording_kind_note(ev));
}

/// Parameters: the metric definitions and thresholds used.
fn parameters_section(h: &mut String, ev: &Evaluation) {
    let c = &ev.config;
    h.push_str(
        "<h2>Parameters</h2>\n<table class=\"kv\"><tr><th>parameter</th><th>value</th></tr>\n",
    );
    let _ = writeln!(
        h,
        "<tr><td>speed</td><td>frame-to-frame Euclidean displacement (px/frame)</td></tr>\n\
<tr><td>fixation (I-VT)</td><td>maximal run of speeds &lt; {} px/frame; duration in frames</td></tr>\n\
<tr><td>saccade (I-VT)</td><td>maximal run of speeds &gt; {} px/frame; amplitude = summed displacement (px)</td></tr>\n\
<tr><td>blink proxy</td><td>run of &ge; {} zero-speed steps (stage 2 forward-fills blinks)</td></tr>\n\
<tr><td>KS test</td><td>two-sided, as scipy.stats.ks_2samp(method='auto'): exact p if max(n1, n2) &le; 10000, else asymptotic</td></tr>\n\
<tr><td>KS D threshold</td><td>D &le; {} passes (the paper's D: 0.006-0.136)</td></tr>\n\
<tr><td>time-series window</td><td>{} s</td></tr>\n<tr><td>Q-Q quantiles per panel</td><td>{}</td></tr>\n\
<tr><td>viewing geometry</td><td>{}</td></tr>",
        c.thresholds.fixation_below_px_per_frame,
        c.thresholds.saccade_above_px_per_frame,
        c.thresholds.hold_min_frames,
        c.d_max,
        {
            // A window longer than a session is shown a session long, on
            // both sides (distribution.rs).
            let session_s = ev.session_frames as f64 / ev.fps;
            if c.window_s > session_s {
                format!("{} (shown {session_s:.1}, a session's length)", c.window_s)
            } else {
                format!("{}", c.window_s)
            }
        },
        c.qq_points,
        c.px_per_deg
            .map_or("not given (no degrees)".into(), |k| format!("{k} px per degree"))
    );
    h.push_str("</table>\n<p>Source pool metrics are computed within each source recording, so the jump where two recordings were concatenated is not counted; each generated session is measured as a whole, as it would be rendered. Sessions overlap (circular slicing), so they are not independent draws.</p>\n");
}

/// Behaviour models against the real recordings of their class, beside
/// the spread between two real people.
fn behaviour_section(h: &mut String, ev: &Evaluation, figs: &[Figure]) {
    if ev.behaviour.is_empty() {
        return;
    }
    let fig = |name: &str| figs.iter().find(|f| f.name == name);
    h.push_str("<h2>Behaviour models against real recordings</h2>\n<p>Within each class's source pool, the recordings a behaviour model generated against the real ones (the same metrics and KS test as above). The scale is the D between two real people of the same class: a model whose D to the real recordings is no larger is as close to them as they are to each other.</p>\n<table><tr><th>class</th><th>metric</th><th>D(model, real)</th><th>D(real, real)</th><th>real pair</th><th>n model</th><th>n real</th><th>within the real spread</th></tr>\n");
    for c in &ev.behaviour {
        for r in &c.rows {
            let pair = r
                .real_pair
                .as_ref()
                .map_or("only one real person".to_string(), |(a, b)| {
                    format!("{a} / {b}")
                });
            h.push_str(&format!(
                "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n",
                c.class,
                r.metric.title(),
                f3(r.d_model),
                f3(r.d_real),
                html_escape(&pair),
                r.n_model,
                r.n_real,
                r.pass().map_or("n/a", verdict)
            ));
        }
    }
    h.push_str("</table>\n");
    if let Some(f) = fig("behaviour_qq") {
        h.push_str(&img(f, "Q-Q plots: real recordings (source quantile) against the behaviour model (generated quantile), per class and metric"));
    }
    if let Some(f) = fig("behaviour_windows") {
        h.push_str(&img(f, "Time series side by side: a real recording (left) and a generated one (right), x and y in canvas px"));
    }
}

/// Distributional fidelity: KS per class and metric, Q-Q and time-series figures.
fn distribution_section(h: &mut String, ev: &Evaluation, figs: &[Figure]) {
    let fig = |name: &str| figs.iter().find(|f| f.name == name);
    let c = &ev.config;
    h.push_str("<h2>Distributional fidelity</h2>\n<table><tr><th>class</th><th>metric</th><th>KS D</th><th>p</th><th>p method</th><th>n source</th><th>n generated</th><th>median source</th><th>median generated</th><th>paper D</th><th>D &le; threshold</th></tr>\n");
    for ce in &ev.classes {
        for cmp in &ce.comparisons {
            let (d, p, m, ok) = match &cmp.ks {
                Some(k) => (
                    format!("{:.4}", k.d),
                    fp(k.p),
                    format!("{:?}", k.method).to_lowercase(),
                    verdict(k.d <= c.d_max).to_string(),
                ),
                None => ("n/a".into(), "n/a".into(), "-".into(), "no samples".into()),
            };
            let _ = writeln!(
                h,
                "<tr><td>{}</td><td>{} ({})</td><td>{d}</td><td>{p}</td><td>{m}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{:.3}</td><td>{ok}</td></tr>",
                ce.class,
                cmp.metric.title(),
                cmp.metric.unit(),
                cmp.n_source,
                cmp.n_generated,
                f3(cmp.median_source),
                f3(cmp.median_generated),
                cmp.metric.paper_d(ce.class)
            );
        }
    }
    h.push_str("</table>\n<p>With tens of thousands of samples, p-values are small even for tiny differences; D is the measure of practical fidelity.</p>\n");
    if let Some(f) = fig("qq") {
        h.push_str(&img(f, "Q-Q plots: generated quantiles against source quantiles, per class and metric; dashed line 1:1; KS D annotated"));
    }
    if let Some(f) = fig("timeseries") {
        h.push_str(&img(f, "Time-series windows: the source pool (left) beside a generated session (right), x and y in canvas px. Each session is a stretch of the pool, cut by circular slicing, speed-scaled and normalized, so a session that starts where the pool starts looks like its first seconds"));
    }
}

/// Beyond the paper: rates, medians, main sequence, events export.
fn extras_section(h: &mut String, ev: &Evaluation, figs: &[Figure]) {
    let fig = |name: &str| figs.iter().find(|f| f.name == name);
    h.push_str("<h2>Beyond the paper</h2>\n<table><tr><th>class</th><th>measure</th><th>source</th><th>generated</th></tr>\n");
    for ce in &ev.classes {
        let (s, g) = (&ce.extras_source, &ce.extras_generated);
        let rows: Vec<(&str, String, String)> = vec![
            (
                "duration (s)",
                format!("{:.1}", s.duration_s),
                format!("{:.1}", g.duration_s),
            ),
            (
                "fixations per second",
                format!("{:.3}", s.fixation_rate_per_s),
                format!("{:.3}", g.fixation_rate_per_s),
            ),
            (
                "saccades per second",
                format!("{:.3}", s.saccade_rate_per_s),
                format!("{:.3}", g.saccade_rate_per_s),
            ),
            (
                "blinks per minute (held-position proxy)",
                format!("{:.2}", s.blink_rate_per_min),
                format!("{:.2}", g.blink_rate_per_min),
            ),
            (
                "blinks per minute (sessions' blink column)",
                "-".to_string(),
                g.blink_column_rate_per_min
                    .map_or("no column".into(), |r| format!("{r:.2}")),
            ),
            (
                "median fixation duration (ms)",
                f3(s.fixation_duration_median_ms),
                f3(g.fixation_duration_median_ms),
            ),
            (
                "median saccade amplitude (px)",
                f3(s.saccade_amplitude_median_px),
                f3(g.saccade_amplitude_median_px),
            ),
            (
                "median saccade amplitude (deg)",
                f3(s.saccade_amplitude_median_deg),
                f3(g.saccade_amplitude_median_deg),
            ),
            (
                "median fixation dispersion (px)",
                f3(s.fixation_dispersion_median_px),
                f3(g.fixation_dispersion_median_px),
            ),
            (
                "median speed (px/s)",
                f3(s.speed_median_px_per_s),
                f3(g.speed_median_px_per_s),
            ),
            (
                "main sequence exponent (peak speed ~ amplitude^e)",
                f3(s.main_sequence_exponent),
                f3(g.main_sequence_exponent),
            ),
        ];
        for (name, a, b) in rows {
            let _ = writeln!(
                h,
                "<tr><td>{}</td><td>{name}</td><td>{a}</td><td>{b}</td></tr>",
                ce.class
            );
        }
    }
    h.push_str("</table>\n");
    if let Some(f) = fig("main_sequence") {
        h.push_str(&img(
            f,
            "Main sequence: saccade amplitude against peak speed (log-log), source and generated",
        ));
    }
    h.push_str("<p>Events of every generated session are exported in pymovements' events layout (<code>name,onset,offset</code>, times in ms from the session start) under <code>report/events/&lt;class&gt;/&lt;session&gt;.csv</code>.</p>\n");
}

/// Visual mapping fidelity and the renderer's ground truth.
fn visual_html(h: &mut String, ev: &Evaluation, figs: &[Figure]) {
    let fig = |name: &str| figs.iter().find(|f| f.name == name);
    h.push_str("<h2>Visual mapping fidelity</h2>\n");
    match &ev.visual {
        VisualSection::NotComputed { reason } => {
            let _ = writeln!(h, "<p class=\"note\">{}</p>", html_escape(reason));
        }
        VisualSection::Computed(run) => {
            let v = &run.fidelity;
            let (lo, hi) = TARGET_AMPLITUDE_RATIO;
            let _ = writeln!(
                h,
                "<p>Video <code>{}</code>, {} frames compared; eye located by: {} (iris measured in {:.1} % of the frames).</p>",
                html_escape(&run.video),
                v.n_frames,
                html_escape(&run.eye_locator),
                100.0 * run.detection_rate
            );
            h.push_str("<p>The errors are per-frame distances between the read-back and the source in normalized iris units (n<sub>x</sub>: the iris from the image-left eye corner, 0, to the image-right one, 1; n<sub>y</sub>: from the upper lid, 0, to the lower, 1). They include a constant offset between the two (the extractor reads the iris a little off where the renderer drew it), which the renderer leaves alone: r and the amplitude ratio, which carry the targets, do not see it. The last column is what the paper's own web simulator gave in its Table 4, for comparison.</p>\n");
            h.push_str("<table><tr><th>measure</th><th>value</th><th>target</th><th>verdict</th><th>the paper's simulator</th></tr>\n");
            let _ = writeln!(h, "<tr><td>mean error (normalized units)</td><td>{:.4}</td><td>-</td><td>-</td><td>0.053</td></tr>", v.error.mean);
            let _ = writeln!(
                h,
                "<tr><td>median error</td><td>{:.4}</td><td>-</td><td>-</td><td>0.036</td></tr>",
                v.error.median
            );
            let _ = writeln!(h, "<tr><td>95th percentile error</td><td>{:.4}</td><td>-</td><td>-</td><td>0.161</td></tr>", v.error.p95);
            for (ax, a, pr, pa) in [("x", &v.x, 0.006, 0.30), ("y", &v.y, 0.077, 0.42)] {
                let (r_ok, a_ok) = (r_meets(a.r, TARGET_R_MIN), ratio_meets(a.amplitude_ratio));
                let _ = writeln!(
                    h,
                    "<tr><td>Pearson r ({ax})</td><td>{}</td><td>&ge; {TARGET_R_MIN}</td><td>{}</td><td>{pr}</td></tr>\n<tr><td>amplitude ratio ({ax}, std rendered / std source)</td><td>{}</td><td>{lo}-{hi}</td><td>{}</td><td>{pa}</td></tr>\n<tr><td>gain ({ax}, slope of rendered on source; the ratio without the read-back's noise, which inflates the ratio by about 1/r)</td><td>{}</td><td>-</td><td>-</td><td>-</td></tr>",
                    f3(a.r),
                    verdict(r_ok),
                    f3(a.amplitude_ratio),
                    verdict(a_ok),
                    f3(a.gain)
                );
            }
            if let Some(inp) = &v.input {
                let _ = writeln!(
                    h,
                    "<tr><td>input range x</td><td>{:.0} px ({:.1} % of canvas width)</td><td>-</td><td>-</td><td>100 px (7.8 %)</td></tr>\n<tr><td>input range y</td><td>{:.0} px ({:.1} % of canvas height)</td><td>-</td><td>-</td><td>155 px (21.5 %)</td></tr>",
                    inp.range_px[0], inp.range_pct_canvas[0], inp.range_px[1], inp.range_pct_canvas[1]
                );
            }
            h.push_str("</table>\n");
            if let Some(f) = fig("visual") {
                h.push_str(&img(f, "Visual fidelity: source and rendered iris position over time per axis; per-frame error histogram"));
            }
        }
    }
    let sessions: usize = ev.classes.iter().map(|c| c.events.len()).sum();
    sessions_read_back_html(h, &ev.sessions_read_back, sessions);
    if let Some((file, t)) = &ev.render_truth {
        let _ = writeln!(
            h,
            "<h3>Renderer ground truth against the source</h3>\n<p>The renderer's own per-frame iris position (<code>{}</code>, mean of both eyes) against the source, without the extractor, {} frames: {}. This isolates the simulator's mapping from extraction error. It has no target: with <code>match_extractor</code> (the default) the eye is drawn through the inverse of the extractor's measured response (the session's <code>_identity.json</code>, <code>mapping.extractor_response</code>), so that the video reads back as the source; where the extractor reads a movement at 0.4 of its size, the eye is drawn 2.5 times as far, and this ratio shows it. The read-back above is the end-to-end measure.</p>",
            html_escape(file),
            t.n_frames,
            t.summary()
        );
    }
}

/// The per-session table, with each class's range first; `sessions`: how
/// many the dataset has (the table may hold a sample of them).
fn sessions_read_back_html(h: &mut String, rows: &[SessionReadBack], sessions: usize) {
    if rows.is_empty() {
        return;
    }
    let (title, which) = if rows.len() >= sessions {
        (
            "Every session read back",
            format!("{} sessions", rows.len()),
        )
    } else {
        (
            "Sessions read back: a sample",
            format!(
                "{} of the {sessions} sessions, the first of each class; <code>--read-back N</code> reads N a class, <code>--read-back-all</code> every one",
                rows.len()
            ),
        )
    };
    let _ = writeln!(
        h,
        "<h3>{title}</h3>\n<p>Each session's whole video read by the extractor and compared frame by frame with its source, open-eye frames only ({which}). Targets as above: r &ge; {TARGET_R_MIN}, amplitude ratio {}-{}.</p>",
        TARGET_AMPLITUDE_RATIO.0,
        TARGET_AMPLITUDE_RATIO.1
    );
    let range = |v: Vec<f64>| {
        let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        if v.is_empty() {
            "n/a".to_string()
        } else {
            format!("{lo:.3}-{hi:.3}")
        }
    };
    // Full-face sessions also read back the head's yaw.
    let heads = rows.iter().any(|r| r.head_yaw.is_some());
    if heads {
        let _ = writeln!(
            h,
            "<p>Head yaw: solved from the 468 landmarks the extractor finds in each full-face video (its first {HEAD_YAW_READ_BACK_S:.0} s at most; the canonical face shape), against the drawn head, each relative to its mean; target r &ge; {TARGET_HEAD_YAW_R_MIN}. The slope departs from 1 as far as the photo's face departs from the canonical shape; r is lower where the head moved little (its drawn yaw sd, last column, against the landmarks' frame-to-frame jitter of a few tenths of a degree).</p>"
        );
    }
    let head_th = if heads {
        "<th>head yaw r</th><th>head yaw slope</th><th>drawn yaw sd (deg)</th>"
    } else {
        ""
    };
    let mut classes: Vec<&str> = rows.iter().map(|r| r.class.as_str()).collect();
    classes.dedup();
    let _ = writeln!(h, "<table><tr><th>class</th><th>sessions</th><th>r x</th><th>amplitude ratio x</th><th>r y</th><th>amplitude ratio y</th>{}</tr>", if heads { "<th>head yaw r</th>" } else { "" });
    for c in classes {
        let of = |f: &dyn Fn(&SessionReadBack) -> Option<f64>| {
            range(rows.iter().filter(|r| r.class == c).filter_map(f).collect())
        };
        let head = if heads {
            format!("<td>{}</td>", of(&|r| r.head_yaw.and_then(|y| y.r)))
        } else {
            String::new()
        };
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td>{head}</tr>",
            html_escape(c),
            rows.iter().filter(|r| r.class == c).count(),
            of(&|r| r.fidelity.x.r),
            of(&|r| r.fidelity.x.amplitude_ratio),
            of(&|r| r.fidelity.y.r),
            of(&|r| r.fidelity.y.amplitude_ratio)
        );
    }
    let _ = writeln!(h, "</table>\n<table><tr><th>session</th><th>frames</th><th>iris found</th><th>r x</th><th>amplitude ratio x</th><th>r y</th><th>amplitude ratio y</th><th>median error</th>{head_th}</tr>");
    // A value that misses its target is marked as the tables above mark
    // a failed check (the summary at the top counts them).
    let r_of = |v: Option<f64>, min: f64| mark(v, r_meets(v, min));
    let ratio = |v: Option<f64>| mark(v, ratio_meets(v));
    for r in rows {
        let v = &r.fidelity;
        let head = match (heads, r.head_yaw) {
            (false, _) => String::new(),
            (true, None) => "<td>n/a</td><td>n/a</td><td>n/a</td>".to_string(),
            (true, Some(y)) => format!(
                "<td>{}</td><td>{}</td><td>{:.2}</td>",
                r_of(y.r, TARGET_HEAD_YAW_R_MIN),
                f3(y.slope),
                y.truth_sd_deg
            ),
        };
        let _ = writeln!(
            h,
            "<tr><td><code>{}</code></td><td>{}</td><td>{:.1} %</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{:.4}</td>{head}</tr>",
            html_escape(&r.session),
            v.n_frames,
            100.0 * r.detection_rate,
            r_of(v.x.r, TARGET_R_MIN),
            ratio(v.x.amplitude_ratio),
            r_of(v.y.r, TARGET_R_MIN),
            ratio(v.y.amplitude_ratio),
            v.error.median
        );
    }
    h.push_str("</table>\n");
    budget_html(h, rows);
}

/// Movement against the extractor's error, for the sessions that have it.
fn budget_html(h: &mut String, rows: &[SessionReadBack]) {
    let with: Vec<(&SessionReadBack, crate::ReadBackBudget)> = rows
        .iter()
        .filter_map(|r| r.budget.map(|b| (r, b)))
        .collect();
    if with.is_empty() {
        return;
    }
    let _ = writeln!(
        h,
        "<h3>Movement against the extractor's error</h3>\n<p>Why a read-back r can be low whatever the renderer draws: how far each session's eyes move (the source's n std times the length it is measured in, the corner-to-corner width for x and the lid-to-lid height for y), against the extractor's own error on the iris centre (std of the drawn minus the read centre), both in image pixels, mean of both eyes, over the compared frames. For an error independent of the movement, r is about m / sqrt(m<sup>2</sup> + e<sup>2</sup>) (movement m, error e): an error half the movement caps r near 0.9; an error that follows the movement, as a gain does, costs less. \"r, drawn iris\" puts the drawn iris centre in place of the read one (corners and lids still as read): where it rises well above r, the iris centre's error is the limit; where it does not, the corners or lids are.</p>\n<table><tr><th>session</th><th>r x</th><th>movement x (px)</th><th>iris error x (px)</th><th>r x, drawn iris</th><th>r y</th><th>movement y (px)</th><th>iris error y (px)</th><th>r y, drawn iris</th></tr>"
    );
    for (r, b) in with {
        let _ = writeln!(
            h,
            "<tr><td><code>{}</code></td><td>{}</td><td>{:.2}</td><td>{:.2}</td><td>{}</td><td>{}</td><td>{:.2}</td><td>{:.2}</td><td>{}</td></tr>",
            html_escape(&r.session),
            f3(r.fidelity.x.r),
            b.x.movement_px,
            b.x.iris_error_px,
            f3(b.x.r_drawn_iris),
            f3(r.fidelity.y.r),
            b.y.movement_px,
            b.y.iris_error_px,
            f3(b.y.r_drawn_iris)
        );
    }
    h.push_str("</table>\n");
}

/// Paths written by [`write_report`].
#[derive(Clone, Debug)]
pub struct ReportPaths {
    pub dir: PathBuf,
    pub html: PathBuf,
    pub metrics: PathBuf,
}

fn file_stem(rel: &str) -> String {
    Path::new(rel).file_stem().map_or_else(
        || rel.replace('/', "_"),
        |s| s.to_string_lossy().into_owned(),
    )
}

/// Writes `<dataset>/report/`: index.html, metrics.json, figures, events.
/// Returns the paths and the metrics.json text.
pub fn write_report(
    dataset_dir: &Path,
    ev: &Evaluation,
) -> Result<(ReportPaths, String), EvalError> {
    check_report_place(dataset_dir)?;
    let final_dir = dataset_dir.join("report");
    // The report is made whole in a folder of its own and then swapped in:
    // an interrupted run leaves the old report or none, never a mix of
    // the two or a report without its index.html. Leftovers of a killed
    // run are removed first.
    remove_report_leftovers(dataset_dir)?;
    let dir = dataset_dir.join(format!(".report.tmp{}", std::process::id()));
    let _listed = eyereplay_core::inflight::InFlight::new(&dir);
    let figs = figures(ev)?;
    for f in &figs {
        atomic_write(&dir.join("figures").join(format!("{}.png", f.name)), &f.png)?;
        atomic_write(
            &dir.join("figures").join(format!("{}.svg", f.name)),
            f.svg.as_bytes(),
        )?;
    }
    for ce in &ev.classes {
        for (file, events) in &ce.events {
            let p = dir
                .join("events")
                .join(ce.class.name())
                .join(format!("{}.csv", file_stem(file)));
            atomic_write(&p, events_csv(events, ev.fps).as_bytes())?;
        }
    }
    let metrics = metrics_json(ev).to_pretty();
    atomic_write(&dir.join("metrics.json"), metrics.as_bytes())?;
    atomic_write(&dir.join("index.html"), report_html(ev, &figs).as_bytes())?;
    swap_in(&dir, &final_dir)?;
    Ok((
        ReportPaths {
            html: final_dir.join("index.html"),
            metrics: final_dir.join("metrics.json"),
            dir: final_dir,
        },
        metrics,
    ))
}

/// The report can take its place in `dataset_dir`: no file is named
/// `report` there (the swap would fail after the evaluation, and used to
/// leave its temporary folder behind). Checked before the evaluation too.
pub fn check_report_place(dataset_dir: &Path) -> Result<(), EvalError> {
    let target = dataset_dir.join("report");
    match std::fs::symlink_metadata(&target) {
        Ok(m) if !m.is_dir() => Err(EvalError::dataset(
            target,
            "a file where the dataset's report folder goes; move it away",
        )),
        _ => Ok(()),
    }
}

/// Removes `.report.tmp*` and `.report.old*` folders a killed run left in
/// `dataset_dir`.
fn remove_report_leftovers(dataset_dir: &Path) -> Result<(), EvalError> {
    let entries = match std::fs::read_dir(dataset_dir) {
        Ok(e) => e,
        Err(e) => return Err(EvalError::io(dataset_dir, e)),
    };
    for entry in entries.flatten() {
        let name = entry.file_name();
        let name = name.to_string_lossy();
        if name.starts_with(".report.tmp") || name.starts_with(".report.old") {
            let p = entry.path();
            let removed = if p.is_dir() {
                std::fs::remove_dir_all(&p)
            } else {
                std::fs::remove_file(&p)
            };
            removed.map_err(|e| EvalError::io(&p, e))?;
        }
    }
    Ok(())
}

/// Puts the finished folder `new` in the place of `target`: the old one
/// is moved aside, the new one renamed in, the old one removed.
fn swap_in(new: &Path, target: &Path) -> Result<(), EvalError> {
    let old = target.with_file_name(format!(".report.old{}", std::process::id()));
    // A stop (Ctrl-C) removes what is left of the old report once it is
    // out of the way...
    let _old_listed = eyereplay_core::inflight::InFlight::new(&old);
    // ... and never falls between the two renames: it finds the old
    // report in place, or the new one.
    let had_old = eyereplay_core::inflight::guarded(|| {
        let had_old = match std::fs::rename(target, &old) {
            Ok(()) => true,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => false,
            Err(e) => return Err(EvalError::io(target, e)),
        };
        if let Err(e) = std::fs::rename(new, target) {
            if had_old {
                let _ = std::fs::rename(&old, target);
            }
            return Err(EvalError::io(target, e));
        }
        Ok(had_old)
    })?;
    if had_old {
        std::fs::remove_dir_all(&old).map_err(|e| EvalError::io(&old, e))?;
    }
    Ok(())
}

/// Metric keys used in metrics.json, in table order.
pub fn metric_keys() -> [&'static str; 3] {
    [
        Metric::Speed.key(),
        Metric::FixationDuration.key(),
        Metric::SaccadeAmplitude.key(),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compare_visual;

    /// The new report takes the old one's place whole: none of the old
    /// files stays beside the new ones, and what a killed run left is
    /// cleared first.
    #[test]
    fn a_new_report_replaces_the_old_one_whole() {
        let d = tempfile::tempdir().unwrap();
        let (report, ds) = (d.path().join("report"), d.path());
        std::fs::create_dir_all(report.join("figures")).unwrap();
        std::fs::write(report.join("figures/old_only.png"), b"old").unwrap();
        std::fs::write(report.join("index.html"), b"old").unwrap();
        let killed = ds.join(".report.tmp999999");
        std::fs::create_dir_all(&killed).unwrap();
        std::fs::write(killed.join("metrics.json"), b"half").unwrap();
        remove_report_leftovers(ds).unwrap();
        assert!(!killed.exists());
        let new = ds.join(".report.tmp1");
        std::fs::create_dir_all(&new).unwrap();
        std::fs::write(new.join("index.html"), b"new").unwrap();
        swap_in(&new, &report).unwrap();
        assert_eq!(std::fs::read(report.join("index.html")).unwrap(), b"new");
        assert!(!report.join("figures").exists());
        let names: Vec<String> = std::fs::read_dir(ds)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        assert_eq!(names, ["report"]);
        // The first report: nothing to move aside.
        std::fs::remove_dir_all(&report).unwrap();
        std::fs::create_dir_all(&new).unwrap();
        swap_in(&new, &report).unwrap();
        assert!(report.is_dir() && !new.exists());
    }

    fn row(session: &str, head_yaw: Option<HeadYawReadBack>) -> SessionReadBack {
        let src: Vec<[f64; 2]> = (0..50)
            .map(|i| [0.5 + 0.01 * (i as f64).sin(), 0.5 + 0.01 * (i as f64).cos()])
            .collect();
        SessionReadBack {
            session: session.into(),
            class: "reading".into(),
            detection_rate: 1.0,
            fidelity: compare_visual(&src, &src, None).unwrap(),
            head_yaw,
            budget: None,
        }
    }

    /// Full-face sessions get head-yaw columns (a session without a head
    /// reads n/a); a dataset without any has none.
    #[test]
    fn head_yaw_columns_only_where_a_session_has_a_head() {
        let yaw = HeadYawReadBack {
            frames: 300,
            frames_read: 300,
            r: Some(0.9871),
            slope: Some(0.8123),
            truth_sd_deg: 2.0,
        };
        let mut h = String::new();
        sessions_read_back_html(
            &mut h,
            &[row("reading/a.csv", Some(yaw)), row("reading/b.csv", None)],
            2,
        );
        assert!(h.contains("<h3>Every session read back</h3>"), "{h}");
        assert!(
            h.contains("<th>head yaw r</th><th>head yaw slope</th><th>drawn yaw sd (deg)</th>"),
            "{h}"
        );
        assert!(
            h.contains("<td>0.987</td><td>0.812</td><td>2.00</td>"),
            "{h}"
        );
        assert!(h.contains("<td>n/a</td><td>n/a</td><td>n/a</td>"), "{h}");
        // The class row's range covers the one session that has a head.
        assert!(h.contains("<td>0.987-0.987</td></tr>"), "{h}");
        let mut h = String::new();
        sessions_read_back_html(&mut h, &[row("reading/a.csv", None)], 12);
        assert!(!h.contains("head yaw"), "{h}");
        // One of twelve: the heading says it is a sample, and how to get more.
        assert!(h.contains("Sessions read back: a sample"), "{h}");
        assert!(h.contains("1 of the 12 sessions"), "{h}");
    }

    /// Each session read back is four checks (r and amplitude ratio per
    /// axis) and one more with a head; the summary counts and names the
    /// misses, and the table marks them. A perfect read-back (the source
    /// itself: r 1, ratio 1) passes; a head yaw r of 0.5 fails its 0.9.
    #[test]
    fn the_summary_counts_every_check_and_names_the_misses() {
        let yaw = HeadYawReadBack {
            frames: 300,
            frames_read: 300,
            r: Some(0.5),
            slope: Some(0.8),
            truth_sd_deg: 2.0,
        };
        let rows = [row("reading/a.csv", None), row("reading/b.csv", Some(yaw))];
        let none = VisualSection::NotComputed {
            reason: "skipped".into(),
        };
        let c = checks_of(&[], &[], &none, &rows, 0.15);
        assert_eq!(c.total, 9);
        assert_eq!(
            c.failing,
            ["read back reading/b.csv: head yaw r 0.500 < 0.9"]
        );
        assert_eq!(c.headline(), "8 of 9 checks pass");
        assert_eq!(
            c.line(),
            "8 of 9 checks pass; failing: read back reading/b.csv: head yaw r 0.500 < 0.9"
        );
        let mut h = String::new();
        sessions_read_back_html(&mut h, &rows, 2);
        assert!(
            h.contains("<td><span class=\"fail\">0.500</span></td><td>0.800</td>"),
            "{h}"
        );
        assert_eq!(h.matches("class=\"fail\"").count(), 1, "{h}");
    }

    /// The budget table lists the sessions that have one, with their r and
    /// the four pixel figures; none at all writes no table.
    #[test]
    fn budget_table_only_for_sessions_with_a_budget() {
        let b = crate::ReadBackBudget {
            frames: 600,
            x: crate::AxisBudget {
                movement_px: 0.654,
                iris_error_px: 0.236,
                r_drawn_iris: Some(0.9391),
            },
            y: crate::AxisBudget {
                movement_px: 0.281,
                iris_error_px: 0.427,
                r_drawn_iris: None,
            },
        };
        let mut with = row("conversation/c.csv", None);
        with.budget = Some(b);
        let mut h = String::new();
        sessions_read_back_html(&mut h, &[with, row("reading/a.csv", None)], 2);
        assert!(h.contains("Movement against the extractor's error"), "{h}");
        assert!(
            h.contains("<tr><td><code>conversation/c.csv</code></td><td>1.000</td><td>0.65</td><td>0.24</td><td>0.939</td><td>1.000</td><td>0.28</td><td>0.43</td><td>n/a</td></tr>"),
            "{h}"
        );
        assert!(
            !h.contains("<tr><td><code>reading/a.csv</code></td><td>1.000</td><td>"),
            "{h}"
        );
        let mut h = String::new();
        sessions_read_back_html(&mut h, &[row("reading/a.csv", None)], 1);
        assert!(!h.contains("Movement against"), "{h}");
    }
}
