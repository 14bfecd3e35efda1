//! Figures, each drawn twice from the same code: PNG (for the HTML report,
//! inlined as base64) and SVG (for papers). Text uses a font embedded in the
//! binary (Ubuntu Light, from the `epaint_default_fonts` crate), so nothing
//! depends on the fonts installed on the machine.

use crate::distribution::{ClassEvaluation, Metric};
use crate::error::DrawError;
use crate::visual::VisualFidelity;
use crate::EvalError;
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::FontStyle;
use std::sync::Once;

const FONT: &str = "sans-serif";
const SRC_COLOR: RGBColor = RGBColor(31, 119, 180);
const GEN_COLOR: RGBColor = RGBColor(255, 127, 14);
const X_COLOR: RGBColor = RGBColor(31, 119, 180);
const Y_COLOR: RGBColor = RGBColor(214, 39, 40);
/// Stretches without a score: grey, as on the reviewer's page.
const NO_SCORE_COLOR: RGBColor = RGBColor(136, 136, 136);

/// One figure in both formats.
#[derive(Clone, Debug)]
pub struct Figure {
    /// File stem, e.g. `qq`.
    pub name: String,
    pub png: Vec<u8>,
    pub svg: String,
    pub size: (u32, u32),
}

fn ensure_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The font bytes are a valid TTF shipped inside the crate.
        let _ = plotters::style::register_font(
            FONT,
            FontStyle::Normal,
            epaint_default_fonts::UBUNTU_LIGHT,
        );
    });
}

type DrawResult = Result<(), DrawError>;

/// A backend's error as a [`DrawError`] (its message, one line as the
/// backend gives it).
fn s<E: std::fmt::Display>(e: E) -> DrawError {
    DrawError(e.to_string())
}

/// Draws with `draw` on a PNG bitmap and on an SVG string.
fn render(
    name: &str,
    size: (u32, u32),
    draw_png: impl FnOnce(&DrawingArea<BitMapBackend<'_>, Shift>) -> DrawResult,
    draw_svg: impl FnOnce(&DrawingArea<SVGBackend<'_>, Shift>) -> DrawResult,
) -> Result<Figure, EvalError> {
    ensure_font();
    let err = |e: DrawError| EvalError::Plot {
        name: name.to_string(),
        message: e.0,
    };
    let mut buf = vec![255u8; size.0 as usize * size.1 as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut buf, size).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(s(e)))?;
        draw_png(&root).map_err(err)?;
        root.present().map_err(|e| err(s(e)))?;
    }
    let mut png_bytes = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut png_bytes, size.0, size.1);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut w = enc.write_header().map_err(|e| err(s(e)))?;
        w.write_image_data(&buf).map_err(|e| err(s(e)))?;
    }
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(s(e)))?;
        draw_svg(&root).map_err(err)?;
        root.present().map_err(|e| err(s(e)))?;
    }
    Ok(Figure {
        name: name.to_string(),
        png: png_bytes,
        svg,
        size,
    })
}

fn padded_range(lo: f64, hi: f64) -> (f64, f64) {
    if !(lo.is_finite() && hi.is_finite()) {
        return (0.0, 1.0);
    }
    if hi - lo <= f64::EPSILON * hi.abs().max(1.0) {
        return (lo - 0.5, hi + 0.5);
    }
    let pad = (hi - lo) * 0.04;
    (lo - pad, hi + pad)
}

fn fmt_p(p: f64) -> String {
    if p == 0.0 {
        "0".into()
    } else if p >= 1e-3 {
        format!("{p:.3}")
    } else {
        format!("{p:.1e}")
    }
}

fn draw_qq_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    c: &ClassEvaluation,
    m: Metric,
    d_max: f64,
) -> DrawResult {
    let cmp = c
        .comparisons
        .iter()
        .find(|x| x.metric == m)
        .expect("every metric compared");
    let title = format!("{} - {} ({})", c.class, m.title(), m.unit());
    if cmp.qq.is_empty() {
        let mut chart = ChartBuilder::on(area)
            .caption(&title, (FONT, 16))
            .margin(10)
            .build_cartesian_2d(0.0..1.0, 0.0..1.0)
            .map_err(s)?;
        chart
            .draw_series(std::iter::once(Text::new(
                format!(
                    "no samples (source {}, generated {})",
                    cmp.n_source, cmp.n_generated
                ),
                (0.05, 0.5),
                (FONT, 14),
            )))
            .map_err(s)?;
        return Ok(());
    }
    let lo = cmp
        .qq
        .iter()
        .map(|p| p.0.min(p.1))
        .fold(f64::INFINITY, f64::min);
    let hi = cmp
        .qq
        .iter()
        .map(|p| p.0.max(p.1))
        .fold(f64::NEG_INFINITY, f64::max);
    let (lo, hi) = padded_range(lo, hi);
    let mut chart = ChartBuilder::on(area)
        .caption(&title, (FONT, 16))
        .margin(10)
        .x_label_area_size(36)
        .y_label_area_size(48)
        .build_cartesian_2d(lo..hi, lo..hi)
        .map_err(s)?;
    chart
        .configure_mesh()
        .x_desc("source quantile")
        .y_desc("generated quantile")
        .label_style((FONT, 12))
        .axis_desc_style((FONT, 13))
        .light_line_style(WHITE)
        .draw()
        .map_err(s)?;
    chart
        .draw_series(DashedLineSeries::new(
            vec![(lo, lo), (hi, hi)],
            6,
            4,
            BLACK.stroke_width(1),
        ))
        .map_err(s)?;
    chart
        .draw_series(
            cmp.qq
                .iter()
                .map(|&(x, y)| Circle::new((x, y), 3, SRC_COLOR.mix(0.8).filled())),
        )
        .map_err(s)?;
    let label = match &cmp.ks {
        // No threshold (the behaviour check judges against the real spread).
        Some(k) if !d_max.is_finite() => format!("D = {:.3}   p = {}", k.d, fmt_p(k.p)),
        Some(k) => format!(
            "D = {:.3} {} {d_max} ({})   p = {}",
            k.d,
            if k.d <= d_max { "<=" } else { ">" },
            if k.d <= d_max { "pass" } else { "fail" },
            fmt_p(k.p)
        ),
        None => "D: n/a".into(),
    };
    chart
        .draw_series(std::iter::once(Text::new(
            label,
            (lo + 0.04 * (hi - lo), hi - 0.06 * (hi - lo)),
            (FONT, 15),
        )))
        .map_err(s)?;
    chart
        .draw_series(std::iter::once(Text::new(
            format!("n = {} / {}", cmp.n_source, cmp.n_generated),
            (lo + 0.04 * (hi - lo), hi - 0.14 * (hi - lo)),
            (FONT, 12),
        )))
        .map_err(s)?;
    Ok(())
}

fn draw_qq<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    classes: &[ClassEvaluation],
    d_max: f64,
) -> DrawResult {
    let panels = root.split_evenly((classes.len(), Metric::ALL.len()));
    for (ci, c) in classes.iter().enumerate() {
        for (mi, &m) in Metric::ALL.iter().enumerate() {
            draw_qq_panel(&panels[ci * Metric::ALL.len() + mi], c, m, d_max)?;
        }
    }
    Ok(())
}

/// Q-Q plots: one panel per class (rows) and metric (columns), the 1:1 line
/// dashed, KS D (against the threshold `d_max`, none when it is infinite)
/// and p annotated.
pub fn qq_figure(classes: &[ClassEvaluation], d_max: f64) -> Result<Figure, EvalError> {
    let size = (1380, 420 * classes.len().max(1) as u32);
    render(
        "qq",
        size,
        |r| draw_qq(r, classes, d_max),
        |r| draw_qq(r, classes, d_max),
    )
}

fn draw_series_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    title: &str,
    pts: &[[f64; 2]],
    fps: f64,
    yr: (f64, f64),
) -> DrawResult {
    let t_max = (pts.len().max(2) - 1) as f64 / fps;
    let mut chart = ChartBuilder::on(area)
        .caption(title, (FONT, 16))
        .margin(10)
        .x_label_area_size(36)
        .y_label_area_size(52)
        .build_cartesian_2d(0.0..t_max, yr.0..yr.1)
        .map_err(s)?;
    chart
        .configure_mesh()
        .x_desc("time (s)")
        .x_label_formatter(&time_tick)
        .y_desc("canvas position (px)")
        .label_style((FONT, 12))
        .axis_desc_style((FONT, 13))
        .light_line_style(WHITE)
        .draw()
        .map_err(s)?;
    time_lines(
        &mut chart,
        area,
        &[(pts, 0, X_COLOR, "x"), (pts, 1, Y_COLOR, "y")],
        fps,
        (10, 16),
    )
}

/// One line per `(points, axis, colour, label)` against time (frame / fps),
/// skipping non-finite values, then the legend on the caption's line of
/// `area` ([`caption_legend`]).
fn time_lines<'a, DB: DrawingBackend + 'a>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    area: &DrawingArea<DB, Shift>,
    lines: &[(&[[f64; 2]], usize, RGBColor, &str)],
    fps: f64,
    (margin_px, caption_px): (i32, i32),
) -> DrawResult {
    for &(pts, axis, color, _) in lines {
        chart
            .draw_series(LineSeries::new(
                pts.iter()
                    .enumerate()
                    .filter(|(_, p)| p[axis].is_finite())
                    .map(|(i, p)| (i as f64 / fps, p[axis])),
                color.stroke_width(1),
            ))
            .map_err(s)?;
    }
    let entries: Vec<(LegendMark, String)> = lines
        .iter()
        .map(|&(_, _, color, label)| (LegendMark::Line(color), label.to_string()))
        .collect();
    caption_legend(area, (margin_px, caption_px), 12, &entries)
}

/// A legend on the caption's line of `area` (its margin and caption font
/// size in px), right of the title: a box inside the plot hid data.
fn caption_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    (margin_px, caption_px): (i32, i32),
    font_px: u32,
    entries: &[(LegendMark, String)],
) -> DrawResult {
    legend_row(
        area,
        area.dim_in_pixel().0 as i32 - margin_px,
        margin_px + caption_px / 2,
        font_px,
        entries,
    )
}

fn draw_windows<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    classes: &[ClassEvaluation],
    fps: f64,
) -> DrawResult {
    let panels = root.split_evenly((classes.len(), 2));
    for (ci, c) in classes.iter().enumerate() {
        let all = c.window_source.iter().chain(&c.window_generated);
        let lo = all
            .clone()
            .map(|p| p[0].min(p[1]))
            .fold(f64::INFINITY, f64::min);
        let hi = all
            .map(|p| p[0].max(p[1]))
            .fold(f64::NEG_INFINITY, f64::max);
        let yr = padded_range(lo, hi);
        let secs = c.window_source.len().max(c.window_generated.len()) as f64 / fps;
        draw_series_panel(
            &panels[ci * 2],
            &format!("{} - source pool, first {secs:.0} s", c.class),
            &c.window_source,
            fps,
            yr,
        )?;
        draw_series_panel(
            &panels[ci * 2 + 1],
            &format!("{} - generated {}", c.class, c.window_generated_file),
            &c.window_generated,
            fps,
            yr,
        )?;
    }
    Ok(())
}

/// Time-series windows, source (left) beside generated (right), per class.
pub fn windows_figure(classes: &[ClassEvaluation], fps: f64) -> Result<Figure, EvalError> {
    let size = (1400, 380 * classes.len().max(1) as u32);
    render(
        "timeseries",
        size,
        |r| draw_windows(r, classes, fps),
        |r| draw_windows(r, classes, fps),
    )
}

/// At most `max` items, evenly strided (deterministic).
fn thin<T: Copy>(v: &[T], max: usize) -> Vec<T> {
    if v.len() <= max {
        return v.to_vec();
    }
    let step = v.len() as f64 / max as f64;
    (0..max).map(|i| v[(i as f64 * step) as usize]).collect()
}

fn draw_main_sequence<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    classes: &[ClassEvaluation],
    fps: f64,
) -> DrawResult {
    let panels = root.split_evenly((1, classes.len()));
    for (ci, c) in classes.iter().enumerate() {
        let pts = |m: &crate::metrics::MetricSamples| -> Vec<(f64, f64)> {
            m.saccade_amplitude_px
                .iter()
                .zip(&m.saccade_peak_speed_px_per_frame)
                .filter(|(a, p)| **a > 0.0 && **p > 0.0)
                .map(|(a, p)| (*a, p * fps))
                // A log axis over an infinite range never ends its ticks.
                .filter(|(a, v)| a.is_finite() && v.is_finite() && *a < 1e100 && *v < 1e100)
                .collect()
        };
        let (sp, gp) = (thin(&pts(&c.source), 3000), thin(&pts(&c.generated), 3000));
        let all = sp.iter().chain(&gp);
        let (xl, xh) = all
            .clone()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |a, p| {
                (a.0.min(p.0), a.1.max(p.0))
            });
        let (yl, yh) = all.fold((f64::INFINITY, f64::NEG_INFINITY), |a, p| {
            (a.0.min(p.1), a.1.max(p.1))
        });
        let (xl, xh) = if xl.is_finite() {
            (xl * 0.9, xh * 1.1)
        } else {
            (1.0, 10.0)
        };
        let (yl, yh) = if yl.is_finite() {
            (yl * 0.9, yh * 1.1)
        } else {
            (1.0, 10.0)
        };
        // The ticks chosen here, not by plotters: its own key points on a
        // log axis left a lower decade without one named tick and drew
        // a bold line at each of 10 000, 11 000, ... in the top one.
        let (x_named, x_minor) = log_ticks(xl, xh);
        let (y_named, y_minor) = log_ticks(yl, yh);
        let mut chart = ChartBuilder::on(&panels[ci])
            .caption(format!("{} - main sequence", c.class), (FONT, 16))
            .margin(10)
            .x_label_area_size(36)
            .y_label_area_size(56)
            .build_cartesian_2d(
                (xl..xh)
                    .log_scale()
                    .with_key_points(x_named)
                    .with_light_points(x_minor),
                (yl..yh)
                    .log_scale()
                    .with_key_points(y_named)
                    .with_light_points(y_minor),
            )
            .map_err(s)?;
        chart
            .configure_mesh()
            .x_desc("saccade amplitude (px)")
            .y_desc("peak speed (px/s)")
            .x_label_formatter(&log_tick_label)
            .y_label_formatter(&log_tick_label)
            .label_style((FONT, 12))
            .axis_desc_style((FONT, 13))
            .bold_line_style(BLACK.mix(0.18))
            .light_line_style(BLACK.mix(0.06))
            .draw()
            .map_err(s)?;
        for (pts, color, name) in [(&sp, SRC_COLOR, "source"), (&gp, GEN_COLOR, "generated")] {
            chart
                .draw_series(
                    pts.iter()
                        .map(|&(x, y)| Circle::new((x, y), 2, color.mix(0.35).filled())),
                )
                .map_err(s)?
                .label(name)
                .legend(move |(x, y)| Circle::new((x + 8, y), 4, color.filled()));
        }
        chart
            .configure_series_labels()
            .label_font((FONT, 13))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .position(SeriesLabelPosition::LowerRight)
            .draw()
            .map_err(s)?;
    }
    Ok(())
}

/// A log axis's ticks over `[lo, hi]`: the named ones, 1, 2 and 5 times
/// each power of ten (the nine of a decade, all named, ran into each
/// other), and the light grid, every whole multiple. A range too narrow
/// to hold two of the named gets every whole multiple named instead, and
/// one without two of those its ends.
fn log_ticks(lo: f64, hi: f64) -> (Vec<f64>, Vec<f64>) {
    let mut named = Vec::new();
    let mut minor = Vec::new();
    if !(lo > 0.0 && hi > lo && hi.is_finite()) {
        return (named, minor);
    }
    let first = lo.log10().floor() as i32;
    let last = hi.log10().ceil() as i32;
    for decade in first..=last {
        let unit = 10f64.powi(decade);
        for m in 1..=9 {
            // Rounded, so that 3 x 0.1 is named 0.3, not 0.30000000000000004.
            let v = (m as f64 * unit * 1e9).round() / 1e9;
            if v < lo || v > hi {
                continue;
            }
            minor.push(v);
            if matches!(m, 1 | 2 | 5) {
                named.push(v);
            }
        }
    }
    if named.len() < 2 {
        named = minor.clone();
    }
    if named.len() < 2 {
        // Inside one step of a decade (all points alike): its ends.
        named = vec![lo, hi];
    }
    (named, minor)
}

/// A log axis's tick label, without a trailing ".0".
fn log_tick_label(v: &f64) -> String {
    if !(*v > 0.0 && v.is_finite()) {
        return String::new();
    }
    if *v >= 1.0 {
        format!("{v:.0}")
    } else {
        format!("{v}")
    }
}

/// Main sequence (saccade amplitude against peak speed, log-log), source
/// and generated overlaid, one panel per class.
pub fn main_sequence_figure(classes: &[ClassEvaluation], fps: f64) -> Result<Figure, EvalError> {
    let size = (600 * classes.len().max(1) as u32, 460);
    render(
        "main_sequence",
        size,
        |r| draw_main_sequence(r, classes, fps),
        |r| draw_main_sequence(r, classes, fps),
    )
}

fn draw_visual<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    v: &VisualFidelity,
    source_n: &[[f64; 2]],
    rendered_n: &[[f64; 2]],
    fps: f64,
) -> DrawResult {
    let (top, bottom) = root.split_vertically(root.dim_in_pixel().1 * 2 / 3);
    let rows = top.split_evenly((2, 1));
    let t_max = (source_n.len().max(2) - 1) as f64 / fps;
    for (axis, name) in [(0usize, "n_x"), (1, "n_y")] {
        let vals = source_n
            .iter()
            .chain(rendered_n)
            .map(|p| p[axis])
            .filter(|v| v.is_finite());
        let lo = vals.clone().fold(f64::INFINITY, f64::min);
        let hi = vals.fold(f64::NEG_INFINITY, f64::max);
        let (lo, hi) = padded_range(lo, hi);
        let af = if axis == 0 { &v.x } else { &v.y };
        let cap = format!(
            "{name}: source vs rendered   r = {}   amplitude ratio = {}",
            af.r.map_or("n/a".into(), |r| format!("{r:.3}")),
            af.amplitude_ratio
                .map_or("n/a".into(), |a| format!("{a:.2}"))
        );
        let mut chart = ChartBuilder::on(&rows[axis])
            .caption(cap, (FONT, 15))
            .margin(8)
            .x_label_area_size(30)
            .y_label_area_size(48)
            .build_cartesian_2d(0.0..t_max, lo..hi)
            .map_err(s)?;
        chart
            .configure_mesh()
            .x_desc("time (s)")
            .x_label_formatter(&time_tick)
            .label_style((FONT, 12))
            .axis_desc_style((FONT, 13))
            .light_line_style(WHITE)
            .draw()
            .map_err(s)?;
        time_lines(
            &mut chart,
            &rows[axis],
            &[
                (source_n, axis, SRC_COLOR, "source"),
                (rendered_n, axis, GEN_COLOR, "rendered"),
            ],
            fps,
            (8, 15),
        )?;
    }
    // Error histogram.
    let bins = 40usize;
    let emax = v.errors.iter().cloned().fold(0.0, f64::max).max(1e-9);
    let width = emax / bins as f64;
    let mut counts = vec![0usize; bins];
    for e in &v.errors {
        counts[((e / width) as usize).min(bins - 1)] += 1;
    }
    let cmax = *counts.iter().max().unwrap_or(&1) as f64;
    let mut chart = ChartBuilder::on(&bottom)
        .caption(
            format!(
                "per-frame error (normalized): mean {:.3}, median {:.3}, p95 {:.3}",
                v.error.mean, v.error.median, v.error.p95
            ),
            (FONT, 15),
        )
        .margin(8)
        .x_label_area_size(30)
        .y_label_area_size(48)
        .build_cartesian_2d(0.0..emax, 0.0..cmax * 1.05)
        .map_err(s)?;
    chart
        .configure_mesh()
        .x_desc("error (normalized iris units: n_x, n_y)")
        .y_desc("frames")
        .x_label_formatter(&|v| {
            if emax < 0.01 {
                format!("{v:.1e}")
            } else {
                format!("{v:.3}")
            }
        })
        .y_label_formatter(&|v| format!("{v:.0}"))
        .label_style((FONT, 12))
        .axis_desc_style((FONT, 13))
        .light_line_style(WHITE)
        .draw()
        .map_err(s)?;
    chart
        .draw_series(counts.iter().enumerate().map(|(i, &c)| {
            Rectangle::new(
                [(i as f64 * width, 0.0), ((i + 1) as f64 * width, c as f64)],
                SRC_COLOR.mix(0.7).filled(),
            )
        }))
        .map_err(s)?;
    Ok(())
}

/// Visual fidelity: both signals over time per axis, and the error histogram.
pub fn visual_figure(
    v: &VisualFidelity,
    source_n: &[[f64; 2]],
    rendered_n: &[[f64; 2]],
    fps: f64,
) -> Result<Figure, EvalError> {
    render(
        "visual",
        (1200, 780),
        |r| draw_visual(r, v, source_n, rendered_n, fps),
        |r| draw_visual(r, v, source_n, rendered_n, fps),
    )
}

/// Gaps (NaN) split a line into pieces so that no segment bridges them.
fn finite_runs(points: impl Iterator<Item = (f64, f64)>) -> Vec<Vec<(f64, f64)>> {
    let mut out: Vec<Vec<(f64, f64)>> = vec![Vec::new()];
    for p in points {
        if p.1.is_finite() {
            out.last_mut().expect("non-empty").push(p);
        } else if !out.last().expect("non-empty").is_empty() {
            out.push(Vec::new());
        }
    }
    out.retain(|r| !r.is_empty());
    out
}

/// The detection figure's outer margin, and the row above its lower
/// panel that holds that panel's legend.
const DETECTION_MARGIN_PX: i32 = 10;
const DETECTION_LEGEND_PX: i32 = 22;
/// The detection figure's title font size.
const DETECTION_TITLE_PX: i32 = 17;

/// A time axis's tick label: whole seconds without a decimal ("20", not
/// "20.0"), fractions with as many decimals as they need (a short clip's
/// axis ticks every 0.5 s).
fn time_tick(v: &f64) -> String {
    let text = format!("{:.3}", v);
    let text = text.trim_end_matches('0').trim_end_matches('.');
    if text == "-0" {
        "0".into()
    } else {
        text.into()
    }
}

/// How a legend entry is drawn: a line, a dashed line or a filled swatch.
#[derive(Clone, Copy)]
enum LegendMark {
    Line(RGBColor),
    Dashed(RGBColor),
    Swatch(RGBAColor),
}

/// Legend entries in one row whose right end is at `right_px` and whose
/// middle is at `y_px` of `area`: drawn beside the plot, not over it, so
/// that no entry hides data (a box in the plot's corner lay over the last
/// half minute's bars).
fn legend_row<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    right_px: i32,
    y_px: i32,
    font_px: u32,
    entries: &[(LegendMark, String)],
) -> DrawResult {
    const MARK_PX: i32 = 16;
    const GAP_PX: i32 = 6;
    const BETWEEN_PX: i32 = 18;
    let font = TextStyle::from((FONT, font_px).into_font()).pos(Pos::new(HPos::Left, VPos::Center));
    let mut widths = Vec::with_capacity(entries.len());
    for (_, text) in entries {
        widths.push(area.estimate_text_size(text, &font).map_err(s)?.0 as i32);
    }
    let total: i32 = widths.iter().map(|w| MARK_PX + GAP_PX + w).sum::<i32>()
        + BETWEEN_PX * (entries.len() as i32 - 1).max(0);
    let mut x = right_px - total;
    for ((mark, text), w) in entries.iter().zip(widths) {
        match *mark {
            LegendMark::Line(c) => area
                .draw(&PathElement::new(
                    vec![(x, y_px), (x + MARK_PX, y_px)],
                    c.stroke_width(2),
                ))
                .map_err(s)?,
            LegendMark::Dashed(c) => {
                for (a, b) in [(0, 6), (10, MARK_PX)] {
                    area.draw(&PathElement::new(vec![(x + a, y_px), (x + b, y_px)], c))
                        .map_err(s)?;
                }
            }
            LegendMark::Swatch(c) => area
                .draw(&Rectangle::new(
                    [(x, y_px - 5), (x + MARK_PX, y_px + 5)],
                    c.filled(),
                ))
                .map_err(s)?,
        }
        x += MARK_PX + GAP_PX;
        area.draw(&Text::new(text.clone(), (x, y_px), font.clone()))
            .map_err(s)?;
        x += w + BETWEEN_PX;
    }
    Ok(())
}

fn draw_detection<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    xy: &[[f64; 2]],
    fps: f64,
    windows: &[(f64, f64, f64)],
    unscored: &[(f64, f64)],
    threshold: f64,
    title: &str,
) -> DrawResult {
    // The legends sit in a row above each panel's plot, right-aligned at
    // the figure's right margin.
    let right_px = root.dim_in_pixel().0 as i32 - DETECTION_MARGIN_PX;
    let (top, bottom) = root.split_vertically(root.dim_in_pixel().1 / 2);
    let t_end = (xy.len() as f64 / fps).max(1.0);
    let finite: Vec<f64> = xy
        .iter()
        .flat_map(|p| p.iter().copied())
        .filter(|v| v.is_finite())
        .collect();
    let lo = finite.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = finite.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let (lo, hi) = padded_range(lo, hi);
    let mut chart = ChartBuilder::on(&top)
        .caption(title, (FONT, DETECTION_TITLE_PX as u32))
        .margin(DETECTION_MARGIN_PX)
        .x_label_area_size(30)
        .y_label_area_size(56)
        .build_cartesian_2d(0.0..t_end, lo..hi)
        .map_err(s)?;
    chart
        .configure_mesh()
        .y_desc("gaze position")
        .x_label_formatter(&time_tick)
        .label_style((FONT, 12))
        .axis_desc_style((FONT, 13))
        .light_line_style(WHITE)
        .draw()
        .map_err(s)?;
    for (k, color) in [(0, X_COLOR), (1, Y_COLOR)] {
        for run in finite_runs(xy.iter().enumerate().map(|(i, p)| (i as f64 / fps, p[k]))) {
            chart
                .draw_series(LineSeries::new(run, color.stroke_width(1)))
                .map_err(s)?;
        }
    }
    caption_legend(
        &top,
        (DETECTION_MARGIN_PX, DETECTION_TITLE_PX),
        13,
        &[
            (LegendMark::Line(X_COLOR), "x".into()),
            (LegendMark::Line(Y_COLOR), "y".into()),
        ],
    )?;
    let mut chart = ChartBuilder::on(&bottom)
        .margin(DETECTION_MARGIN_PX)
        .margin_top(DETECTION_MARGIN_PX + DETECTION_LEGEND_PX)
        .x_label_area_size(36)
        .y_label_area_size(56)
        // A little room under 0: a bar's fill and white edge reach a pixel
        // past its end and would paint over the x axis, which then showed
        // only where no window was scored.
        .build_cartesian_2d(0.0..t_end, -0.01..1.0)
        .map_err(s)?;
    chart
        .configure_mesh()
        .x_desc("time (s)")
        .y_desc("P(reading)")
        .x_label_formatter(&time_tick)
        .label_style((FONT, 12))
        .axis_desc_style((FONT, 13))
        .light_line_style(WHITE)
        .draw()
        .map_err(s)?;
    // Without it a stretch no window could score and a window that scored
    // near 0 looked alike: both left the panel empty.
    chart
        .draw_series(
            unscored.iter().map(|&(a, b)| {
                Rectangle::new([(a, 0.0), (b, 1.0)], NO_SCORE_COLOR.mix(0.3).filled())
            }),
        )
        .map_err(s)?;
    let color_of = |p: f64| if p >= threshold { GEN_COLOR } else { SRC_COLOR };
    chart
        .draw_series(
            windows.iter().map(|&(a, b, p)| {
                Rectangle::new([(a, 0.0), (b, p)], color_of(p).mix(0.6).filled())
            }),
        )
        .map_err(s)?;
    // A white edge between windows, so that neighbours of equal height
    // read as separate windows.
    chart
        .draw_series(
            windows
                .iter()
                .map(|&(a, b, p)| Rectangle::new([(a, 0.0), (b, p)], WHITE.stroke_width(2))),
        )
        .map_err(s)?;
    // Each window's score as a line across it, so that a window scored
    // near 0, whose bar has no height, still shows that it was scored.
    chart
        .draw_series(windows.iter().map(|&(a, b, p)| {
            let inset = (b - a) * 0.02;
            PathElement::new(
                vec![(a + inset, p), (b - inset, p)],
                color_of(p).stroke_width(2),
            )
        }))
        .map_err(s)?;
    chart
        .draw_series(DashedLineSeries::new(
            vec![(0.0, threshold), (t_end, threshold)],
            6,
            4,
            BLACK.stroke_width(1),
        ))
        .map_err(s)?;
    let mut legend = vec![
        (
            LegendMark::Swatch(GEN_COLOR.mix(0.6)),
            "reading".to_string(),
        ),
        (
            LegendMark::Swatch(SRC_COLOR.mix(0.6)),
            "not reading".to_string(),
        ),
        (
            LegendMark::Dashed(BLACK),
            format!("threshold {threshold:.2}"),
        ),
    ];
    if !unscored.is_empty() {
        legend.push((
            LegendMark::Swatch(NO_SCORE_COLOR.mix(0.3)),
            "no score: too little gaze".into(),
        ));
    }
    legend_row(
        &bottom,
        right_px,
        DETECTION_MARGIN_PX + DETECTION_LEGEND_PX / 2,
        13,
        &legend,
    )
}

/// The detector's view of one recording: the gaze track (x and y over
/// time, gaps left open) above the reading probability of each window
/// (orange at or above the threshold, blue below), the threshold dashed,
/// and the `unscored` stretches (start, end in seconds) grey.
pub fn detection_figure(
    xy: &[[f64; 2]],
    fps: f64,
    windows: &[(f64, f64, f64)],
    unscored: &[(f64, f64)],
    threshold: f64,
    title: &str,
) -> Result<Figure, EvalError> {
    render(
        "detection",
        (1200, 560),
        |r| draw_detection(r, xy, fps, windows, unscored, threshold, title),
        |r| draw_detection(r, xy, fps, windows, unscored, threshold, title),
    )
}

/// One ROC curve of [`roc_figure`]: its label and its points.
pub struct RocCurve {
    pub label: String,
    pub points: Vec<(f64, f64)>,
}

/// Curves in the unit square with the diagonal dashed: ROC curves (chance)
/// and reliability diagrams (perfect calibration).
fn draw_unit_curves<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    curves: &[RocCurve],
    (x_desc, y_desc): (&str, &str),
    markers: bool,
) -> DrawResult {
    const COLORS: [RGBColor; 6] = [
        RGBColor(31, 119, 180),
        RGBColor(255, 127, 14),
        RGBColor(44, 160, 44),
        RGBColor(214, 39, 40),
        RGBColor(148, 103, 189),
        RGBColor(140, 86, 75),
    ];
    let mut chart = ChartBuilder::on(root)
        .caption(title, (FONT, 16))
        .margin(10)
        .x_label_area_size(36)
        .y_label_area_size(48)
        .build_cartesian_2d(0.0..1.0, 0.0..1.0)
        .map_err(s)?;
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .y_desc(y_desc)
        .label_style((FONT, 12))
        .axis_desc_style((FONT, 13))
        .light_line_style(WHITE)
        .draw()
        .map_err(s)?;
    chart
        .draw_series(DashedLineSeries::new(
            vec![(0.0, 0.0), (1.0, 1.0)],
            6,
            4,
            BLACK.mix(0.5).stroke_width(1),
        ))
        .map_err(s)?;
    for (i, c) in curves.iter().enumerate() {
        let color = COLORS[i % COLORS.len()];
        if markers {
            chart
                .draw_series(PointSeries::of_element(
                    c.points.clone(),
                    3,
                    color.filled(),
                    &|p, size, style| Circle::new(p, size, style),
                ))
                .map_err(s)?;
        }
        chart
            .draw_series(LineSeries::new(c.points.clone(), color.stroke_width(2)))
            .map_err(s)?
            .label(c.label.clone())
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 16, y)], color.stroke_width(2))
            });
    }
    chart
        .configure_series_labels()
        .label_font((FONT, 12))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(SeriesLabelPosition::LowerRight)
        .draw()
        .map_err(s)?;
    Ok(())
}

/// ROC curves in one panel per entry of `panels` (title, curves), side by
/// side; the chance diagonal dashed.
pub fn roc_figure(name: &str, panels: &[(String, Vec<RocCurve>)]) -> Result<Figure, EvalError> {
    unit_panels(
        name,
        panels,
        ("false-positive rate", "true-positive rate"),
        false,
    )
}

/// Reliability diagrams, one panel per entry of `panels` (title, curves
/// of (mean predicted probability, observed share) per bin): a calibrated
/// model's points lie on the dashed diagonal.
pub fn reliability_figure(
    name: &str,
    panels: &[(String, Vec<RocCurve>)],
) -> Result<Figure, EvalError> {
    unit_panels(
        name,
        panels,
        ("predicted probability of reading", "observed share reading"),
        true,
    )
}

/// Panels of curves in the unit square, side by side.
fn unit_panels(
    name: &str,
    panels: &[(String, Vec<RocCurve>)],
    axes: (&str, &str),
    markers: bool,
) -> Result<Figure, EvalError> {
    let n = panels.len().max(1) as u32;
    render(
        name,
        (440 * n, 440),
        |r| draw_unit_panels(r, panels, axes, markers),
        |r| draw_unit_panels(r, panels, axes, markers),
    )
}

fn draw_unit_panels<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    panels: &[(String, Vec<RocCurve>)],
    axes: (&str, &str),
    markers: bool,
) -> DrawResult {
    let areas = root.split_evenly((1, panels.len().max(1)));
    for (a, (t, c)) in areas.iter().zip(panels) {
        draw_unit_curves(a, t, c, axes, markers)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 60 s of gaze, windows at 0-10 and 50-60 s: the stretch between
    /// them without a score is drawn grey and named in the legend; with no
    /// such stretch neither appears. The window scored 0.02 shows as a
    /// line, and the legends lie outside the plots.
    #[test]
    fn the_detection_figure_greys_what_could_not_be_scored() {
        let xy = vec![[0.5, 0.5]; 1500];
        let windows = [(0.0, 10.0, 0.9), (50.0, 60.0, 0.02)];
        let grey = "opacity=\"0.3\" fill=\"#888888\"";
        let fig = detection_figure(&xy, 25.0, &windows, &[(12.0, 48.0)], 0.6, "t").unwrap();
        assert!(fig.svg.contains("no score: too little gaze"));
        // The stretch and its legend swatch.
        assert_eq!(fig.svg.matches(grey).count(), 2, "{}", fig.svg);
        // The lower panel's plot spans x 66 (margin 10, y labels 56) to
        // 1189 (plotters maps onto 1123 of the 1124 px up to the margin)
        // over 60 s: 12 s falls at 66 + 12 / 60 * 1123 = 290.6, 48 s at
        // 964.4. It spans y from 312 (the bottom half starts at 280, then
        // margin 10 and the legend's row of 22) to 514 (560 less margin 10
        // and x labels 36), 202 px for P from 1 down to -0.01: P = 1 at
        // 312, P = 0 at 312 + 202 / 1.01 = 512.
        assert!(
            fig.svg.contains(&format!(
                "<rect x=\"290\" y=\"312\" width=\"674\" height=\"200\" {grey}"
            )),
            "{}",
            fig.svg
        );
        // The 0.02 window's line: 2 % inset from its ends, 50.2 s at
        // 1005.6 and 59.8 s at 1185.6; P = 0.02 at 312 + 0.98 * 200 = 508.
        assert!(
            fig.svg.contains("points=\"1005,508 1185,508 \""),
            "{}",
            fig.svg
        );
        // Every legend swatch (the bars' two colours and the grey) ends
        // above the plot's top at 312.
        let swatches: Vec<&str> = fig
            .svg
            .lines()
            .filter(|l| l.contains("width=\"16\" height=\"10\""))
            .collect();
        assert_eq!(swatches.len(), 3, "{}", fig.svg);
        for l in swatches {
            let y: i32 = l
                .split("y=\"")
                .nth(1)
                .unwrap()
                .split('"')
                .next()
                .unwrap()
                .parse()
                .unwrap();
            assert!(y + 10 <= 312, "{l}");
        }
        let fig = detection_figure(&xy, 25.0, &windows, &[], 0.6, "t").unwrap();
        assert!(!fig.svg.contains("no score") && !fig.svg.contains(grey));
    }

    #[test]
    fn time_ticks_drop_a_whole_seconds_decimals_only() {
        let named: Vec<String> = [0.0, 20.0, 2.5, 0.25, 7.000_000_1, -0.0001]
            .iter()
            .map(time_tick)
            .collect();
        assert_eq!(named, ["0", "20", "2.5", "0.25", "7", "0"]);
    }

    #[test]
    fn log_ticks_name_one_two_and_five_per_decade() {
        // 15-1100 px: named 20, 50, 100, 200, 500, 1000; the grid every
        // whole multiple, 20-90, 100-900, 1000.
        let (named, minor) = log_ticks(15.0, 1100.0);
        assert_eq!(named, [20.0, 50.0, 100.0, 200.0, 500.0, 1000.0]);
        assert_eq!(minor.len(), 8 + 9 + 1);
        assert_eq!((minor[0], minor[17]), (20.0, 1000.0));
        let labels: Vec<String> = named.iter().map(log_tick_label).collect();
        assert_eq!(labels, ["20", "50", "100", "200", "500", "1000"]);
        // Below 1, as a fraction: 0.3 named 0.3.
        let (named, _) = log_ticks(0.25, 0.6);
        assert_eq!(
            named.iter().map(log_tick_label).collect::<Vec<_>>(),
            ["0.3", "0.4", "0.5", "0.6"]
        );
        // 310-390 holds no 1-2-5 tick and no whole multiple: its ends.
        assert_eq!(log_ticks(310.0, 390.0), (vec![310.0, 390.0], vec![]));
        assert_eq!(log_ticks(0.0, 10.0), (vec![], vec![]));
    }
}
