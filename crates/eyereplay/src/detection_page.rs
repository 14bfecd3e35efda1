//! A reviewer's page for one detection (`<name>_detect.html`): the video
//! (when the input is one) with a playhead, the gaze trace and the reading
//! probability on one timeline below it, reading segments marked; clicking
//! a segment or the timeline seeks the video. One HTML file with its
//! drawing inline and no script or style from elsewhere; the video is
//! linked by a path relative to the page, not copied into it.

use crate::detector::Detection;
use eyereplay_detect::{Track, FPS};
use eyereplay_eval::html_escape as esc;
use std::fmt::Write as _;
use std::path::Path;

/// Timeline drawing size, in SVG user units.
const W: f64 = 1000.0;
const H_GAZE: f64 = 90.0;
const H_PROB: f64 = 110.0;

/// The page's HTML. `video_href` is the video's path relative to the page,
/// when the input is a video.
pub fn detection_page(track: &Track, d: &Detection, video_href: Option<&str>) -> String {
    let dur = track.duration_s().max(d.localization.step_s);
    let x = |t: f64| (t / dur * W).clamp(0.0, W);
    let mut svg = String::new();
    let gaze_band = GazeBand::of(track);
    let mut path = String::new();
    let step = (track.len() / 2000).max(1);
    let mut pen_up = true;
    for (k, p) in track.xy.iter().enumerate().step_by(step) {
        if !p[0].is_finite() {
            pen_up = true;
            continue;
        }
        let _ = write!(
            path,
            "{}{:.1},{:.1} ",
            if pen_up { "M" } else { "L" },
            x(k as f64 / FPS),
            gaze_band.y(p[0])
        );
        pen_up = false;
    }
    let _ = write!(svg, "<path d=\"{path}\" class=\"gaze\"/>");
    // Probability per second, the 0.5 line, segments.
    let top = H_GAZE + 10.0;
    let yp = |p: f64| top + (1.0 - p) * H_PROB;
    // A rect over the whole timeline's height from `a` to `b` seconds, of
    // `class`, with `more` attributes and a hover `title` (HTML-escaped
    // here).
    let band = |svg: &mut String, class: &str, (a, b): (f64, f64), more: &str, title: &str| {
        let _ = write!(
            svg,
            "<rect class=\"{class}\" x=\"{:.1}\" y=\"0\" width=\"{:.1}\" height=\"{:.1}\"{more}><title>{}</title></rect>",
            x(a),
            (x(b) - x(a)).max(1.0),
            top + H_PROB,
            esc(title)
        );
    };
    for g in &d.localization.segments {
        band(
            &mut svg,
            "seg",
            (g.start_s, g.end_s),
            &format!(" data-start=\"{0:.2}\" onclick=\"seek({0:.2})\"", g.start_s),
            &format!(
                "reading {:.1}-{:.1} s, confidence {:.2}",
                g.start_s, g.end_s, g.confidence
            ),
        );
    }
    // Stretches no window could score, with why.
    let unscored = d.unscored();
    for u in unscored {
        band(
            &mut svg,
            "gap",
            (u.start_s, u.end_s),
            "",
            &format!(
                "{}-{}: {}",
                clock(u.start_s),
                clock(u.end_s),
                u.reason(d.model.window_s)
            ),
        );
    }
    // One value a step, as a path broken where there is none.
    let path_of = |values: &[Option<f64>]| -> String {
        let mut path = String::new();
        let mut pen_up = true;
        for (k, p) in values.iter().enumerate() {
            match p {
                Some(p) => {
                    let t = (k as f64 + 0.5) * d.localization.step_s;
                    let _ = write!(
                        path,
                        "{}{:.1},{:.1} ",
                        if pen_up { "M" } else { "L" },
                        x(t),
                        yp(*p)
                    );
                    pen_up = false;
                }
                None => pen_up = true,
            }
        }
        path
    };
    let prob = path_of(&d.localization.probability);
    // The window scores the segments' ends are found on, under the
    // smoothed curve, so that a segment reaching past where that curve
    // passes one half shows why.
    let window_mean = if shows_window_mean(d) {
        format!(
            "<path d=\"{}\" class=\"wmean\"/>",
            path_of(&d.localization.window_mean)
        )
    } else {
        String::new()
    };
    let h = top + H_PROB;
    let _ = write!(
        svg,
        "<line x1=\"0\" x2=\"{W}\" y1=\"{y:.1}\" y2=\"{y:.1}\" class=\"half\"/>{window_mean}<path d=\"{prob}\" class=\"prob\"/><line id=\"head\" x1=\"0\" x2=\"0\" y1=\"0\" y2=\"{h:.1}\" class=\"head\"/>",
        y = yp(0.5),
    );
    // A short clip's scored stretch, shaded: the page's one figure for it.
    if let Some(c) = &d.clip {
        band(
            &mut svg,
            "clip",
            (c.start_s, c.end_s),
            "",
            &format!(
                "scored: {:.1} s of gaze in {:.1}-{:.1} s",
                c.usable_s, c.start_s, c.end_s
            ),
        );
        // Its score as a level over the stretch, in its interval's band.
        let _ = write!(
            svg,
            "<rect class=\"ci\" x=\"{:.1}\" y=\"{:.1}\" width=\"{:.1}\" height=\"{:.1}\"/><line class=\"prob\" x1=\"{:.1}\" x2=\"{:.1}\" y1=\"{y:.1}\" y2=\"{y:.1}\"/>",
            x(c.start_s),
            yp(c.high),
            (x(c.end_s) - x(c.start_s)).max(1.0),
            (yp(c.low) - yp(c.high)).max(1.0),
            x(c.start_s),
            x(c.end_s),
            y = yp(c.reading_probability),
        );
    }
    // Time ticks: lines in the drawing, their labels in HTML below it, so
    // that the text keeps its size however wide the page is.
    let step_s = tick_step_s(dur);
    let mut ticks = String::new();
    for k in 0..=(dur / step_s).floor() as usize {
        let t = k as f64 * step_s;
        if k > 0 {
            let _ = write!(
                svg,
                "<line class=\"tick\" x1=\"{0:.1}\" x2=\"{0:.1}\" y1=\"0\" y2=\"{h:.1}\"/>",
                x(t)
            );
        }
        // One at the right edge ends there, not half past it.
        let at = 100.0 * t / dur;
        let _ = write!(
            ticks,
            "<span style=\"left:{at:.2}%\"{}>{}</span>",
            if at > 96.0 { " class=\"end\"" } else { "" },
            clock(t)
        );
    }
    let segments: String = if d.clip.is_some() {
        "<li>none: a clip shorter than one window is scored whole (above)</li>".into()
    } else if d.localization.segments.is_empty() {
        "<li>none</li>".into()
    } else {
        d.localization
            .segments
            .iter()
            .map(|g| {
                format!(
                    "<li>{} (confidence {:.2})</li>",
                    seek_link(g.start_s, g.end_s),
                    g.confidence
                )
            })
            .collect()
    };
    let not_scored: String = if unscored.is_empty() {
        String::new()
    } else {
        let items: String = unscored
            .iter()
            .map(|u| {
                format!(
                    "<li>{}: {}</li>",
                    seek_link(u.start_s, u.end_s),
                    esc(&u.reason(d.model.window_s))
                )
            })
            .collect();
        format!("<h2>Not scored</h2><ul>{items}</ul>")
    };
    let video = match video_href {
        Some(h) => format!(
            "<video id=\"v\" src=\"{}\" controls preload=\"metadata\"></video>",
            esc(&url_path(h))
        ),
        None => format!("<p class=\"note\">{}</p>", no_video_note(&d.input.kind)),
    };
    // The legend names only what is drawn.
    let mut legend = vec![format!("0 to {}", clock(dur))];
    if !d.localization.segments.is_empty() {
        legend.push(format!(
            "orange: reading segments{}, their ends where the window scores cross half-way between reading and not",
            if video_href.is_some() { " (click to play from there)" } else { "" }
        ));
    }
    if d.localization.probability.iter().any(Option::is_some) {
        legend.push(format!(
            "curve: P(reading), dashed: P = 0.5 (the verdict above compares the mean P with the model's threshold, {:.3})",
            d.model.threshold
        ));
    }
    if shows_window_mean(d) {
        legend.push(
            "grey curve: the mean score of the windows covering each second, before the smoothing"
                .into(),
        );
    }
    if let Some(c) = &d.clip {
        legend.push(format!(
            "blue: the stretch scored, its P(reading) the orange line, its {:.0} % interval the band; dashed: P = 0.5",
            100.0 * c.level
        ));
    }
    if !unscored.is_empty() {
        legend.push("grey: no score, too little gaze (hover for why)".into());
    }
    format!(
        "<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\">\
<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\"><title>{title}</title><style>\
body{{font:15px system-ui,sans-serif;margin:24px auto;padding:0 12px;max-width:1040px;color:#222}}\
video{{width:100%;max-height:480px;background:#000}}.tl{{position:relative}}\
svg{{display:block;box-sizing:border-box;width:100%;height:{h:.0}px;border:1px solid #ccc;cursor:pointer}}\
path,line{{vector-effect:non-scaling-stroke}}\
.gaze{{fill:none;stroke:#456;stroke-width:1}}.prob{{fill:none;stroke:#c60;stroke-width:2}}.wmean{{fill:none;stroke:#888;stroke-width:1}}\
.half{{stroke:#999;stroke-dasharray:4 4}}.tick{{stroke:#ddd;stroke-width:1}}.seg{{fill:#fc8;opacity:.45}}.seg:hover{{opacity:.8}}\
.gap{{fill:#888;opacity:.3}}.clip{{fill:#8bd;opacity:.2}}.ci{{fill:#c60;opacity:.2}}.head{{stroke:#d00;stroke-width:2}}\
.lab{{position:absolute;left:5px;font-size:12px;color:#555;pointer-events:none}}\
.ticks{{position:relative;height:18px;margin:2px 0 0;font-size:12px;color:#555}}\
.ticks span{{position:absolute;top:0;transform:translateX(-50%);white-space:nowrap}}.ticks span:first-child{{transform:none}}.ticks .end{{transform:translateX(-100%)}}\
.note{{color:#666}}</style></head><body>\
<h1>{title}</h1><p><b>{when}</b>. {average} Model: {model}.</p>{video}\
<div class=\"tl\"><svg id=\"t\" viewBox=\"0 0 {W} {h:.0}\" preserveAspectRatio=\"none\">{svg}</svg>\
<span class=\"lab\" style=\"top:2px\">gaze x</span><span class=\"lab\" style=\"top:{prob_top:.0}px\">P(reading)</span></div>\
<div class=\"ticks\">{ticks}</div>\
<p class=\"note\">{legend}.</p>\
<h2>Reading segments</h2><ul>{segments}</ul>{not_scored}\
<script>\
var v=document.getElementById('v'),t=document.getElementById('t'),h=document.getElementById('head'),D={durs:.3};\
function seek(s){{if(v){{v.currentTime=s;v.play();}}}}\
t.addEventListener('click',function(e){{if(e.target.classList.contains('seg'))return;var r=t.getBoundingClientRect();seek((e.clientX-r.left)/r.width*D);}});\
if(v)v.addEventListener('timeupdate',function(){{var x=v.currentTime/D*{W};h.setAttribute('x1',x);h.setAttribute('x2',x);}});\
</script></body></html>\n",
        title = esc(&format!("Reading detection: {}", file_name(&d.input.path))),
        average = esc(&average(d)),
        when = esc(&when(d, dur)),
        model = esc(&d.model.path),
        prob_top = top + 2.0,
        durs = dur,
        legend = esc(&legend.join("; ")),
    )
}

/// Whether the page draws the window mean beside P(reading): where the
/// localization smoothed it (with the window mean alone they are one
/// curve) and the detection kept it.
fn shows_window_mean(d: &Detection) -> bool {
    d.localization.method != eyereplay_detect::localize::Method::WindowMean
        && d.localization.window_mean.iter().any(Option::is_some)
}

/// The step between the timeline's time labels: the smallest of a
/// player's usual steps that gives at most six, so that they fit side by
/// side on a phone's 390 px.
fn tick_step_s(dur_s: f64) -> f64 {
    const STEPS_S: [f64; 14] = [
        1.0, 2.0, 5.0, 10.0, 15.0, 30.0, 60.0, 120.0, 300.0, 600.0, 900.0, 1800.0, 3600.0, 7200.0,
    ];
    STEPS_S
        .into_iter()
        .find(|s| dur_s / s <= 6.0)
        .unwrap_or_else(|| (dur_s / 6.0 / 3600.0).ceil() * 3600.0)
}

/// What stands where the video would: why there is none.
fn no_video_note(kind: &str) -> &'static str {
    match kind {
        "live" => "A live stream: its video was not kept, so the timeline stands alone.",
        "frames" => "Frames given in memory: no video file to show, so the timeline stands alone.",
        _ => "The input is a gaze file, not a video: the timeline alone.",
    }
}

/// The video's address with every byte but a path's plain characters
/// percent-encoded: a `#` or `?` in a file name ("Interview #3.mp4") would
/// otherwise end the path there and leave a dead video.
fn url_path(href: &str) -> String {
    let (scheme, path) = match href.strip_prefix("file://") {
        Some(p) => ("file://", p),
        None => ("", href),
    };
    let mut out = String::from(scheme);
    for b in path.bytes() {
        if b.is_ascii_alphanumeric() || b"-._~/".contains(&b) {
            out.push(b as char);
        } else {
            let _ = write!(out, "%{b:02X}");
        }
    }
    out
}

/// The gaze trace's vertical scale: the 0.5-99.5 % range of x fills the
/// strip. A 5-95 % range (the detector's own unit) flattened every look
/// away from the camera into a line at the strip's edge, yet those looks
/// are what a reviewer scans for beside the reading segments; the extreme
/// half percent on each side is left out so that a single-frame tracking
/// glitch cannot squash the rest of the trace into a thin band.
struct GazeBand {
    lo: f64,
    hi: f64,
}

impl GazeBand {
    const TAIL: f64 = 0.005;

    fn of(track: &Track) -> Self {
        let (lo, hi) = track
            .x_quantiles(Self::TAIL, 1.0 - Self::TAIL)
            .unwrap_or((0.0, 1.0));
        GazeBand { lo, hi }
    }

    /// SVG y of gaze `x`: `lo` at the strip's foot, `hi` at its top, 5 units
    /// of margin; the clipped tails at the strip's edges.
    fn y(&self, x: f64) -> f64 {
        let u = (x - self.lo) / (self.hi - self.lo).max(1e-12);
        (H_GAZE - 5.0 - u * (H_GAZE - 10.0)).clamp(0.0, H_GAZE)
    }
}

/// The headline: how much of the recording is read, in how many segments.
fn when(d: &Detection, dur: f64) -> String {
    if d.clip.is_some() {
        return format!("A short clip: {}", d.verdict);
    }
    let segs = &d.localization.segments;
    if segs.is_empty() {
        return "No reading segment".into();
    }
    let read: f64 = segs.iter().map(|g| g.duration_s()).sum();
    format!(
        "Reading in {} segment{}: {} of {}",
        segs.len(),
        if segs.len() == 1 { "" } else { "s" },
        clock(read),
        clock(dur)
    )
}

/// The whole recording's one verdict, worded so that it does not read as
/// a contradiction of the segments beside it: a long interview with one
/// read answer is "not reading" on average.
fn average(d: &Detection) -> String {
    if let Some(summary) = d.clip_summary() {
        let why = if d.verdict == "uncertain" {
            ": uncertain, since the interval holds the threshold"
        } else {
            ""
        };
        // What `detect` prints for it: the stretch, the score, its interval.
        return format!(
            "Shorter than one {} s window, so scored from its best stretch: {summary}{why}.",
            d.model.window_s
        );
    }
    let said = format!(
        "Averaged over the whole recording, P(reading) is {:.3} against the model's threshold {:.3}",
        d.reading_probability, d.model.threshold
    );
    if d.localization.segments.is_empty() {
        format!("{said}: {}.", d.verdict)
    } else {
        format!("{said} ({} on average; the segments say when).", d.verdict)
    }
}

/// A list entry's link: the stretch as `m:ss - m:ss`, playing the video
/// from its start when clicked.
fn seek_link(start_s: f64, end_s: f64) -> String {
    format!(
        "<a href=\"#\" onclick=\"seek({start_s:.2});return false\">{} - {}</a>",
        clock(start_s),
        clock(end_s)
    )
}

/// `m:ss` (or `h:mm:ss`).
fn clock(s: f64) -> String {
    let s = s.max(0.0).round() as u64;
    if s >= 3600 {
        format!("{}:{:02}:{:02}", s / 3600, s / 60 % 60, s % 60)
    } else {
        format!("{}:{:02}", s / 60, s % 60)
    }
}

fn file_name(path: &str) -> String {
    Path::new(path)
        .file_name()
        .map_or_else(|| path.to_string(), |n| n.to_string_lossy().into_owned())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 95 % of the frames spread over x in [0, 1), 4 % a look away at
    /// x = 3, one frame a tracking glitch at x = 100. By hand: the 99.5 %
    /// quantile of the 1000 values falls among the 40 at 3 and the 0.5 %
    /// one among the evenly spread ones near 0.
    #[test]
    fn gaze_band_keeps_looks_away_and_drops_glitches() {
        let mut xy: Vec<[f64; 2]> = (0..959).map(|i| [i as f64 / 959.0, 0.0]).collect();
        xy.extend((0..40).map(|_| [3.0, 0.0]));
        xy.push([100.0, 0.0]);
        xy.push([f64::NAN, f64::NAN]);
        let band = GazeBand::of(&Track::new(xy));
        assert_eq!(band.hi, 3.0);
        assert!(band.lo >= 0.0 && band.lo < 0.01, "lo {}", band.lo);
        // The look away is drawn at the top, well above the ordinary
        // range (at 5-95 % it was clamped flat at the strip's edge, level
        // with x = 1).
        assert!((band.y(3.0) - 5.0).abs() < 1e-9);
        assert!(band.y(1.0) > band.y(3.0) + 40.0, "y(1) {}", band.y(1.0));
        assert!((band.y(band.lo) - (H_GAZE - 5.0)).abs() < 1e-9);
        // The glitch is clamped inside the strip.
        assert_eq!(band.y(100.0), 0.0);
    }

    /// A 60-s detection with one reading segment and one stretch without
    /// gaze: the page draws the stretch grey with its reason and lists it
    /// with a link that seeks there; a short clip's page (scored whole)
    /// draws none.
    #[test]
    fn the_page_marks_and_lists_what_could_not_be_scored() {
        let mut d: Detection = serde_json::from_value(serde_json::json!({
            "input": {"path": "call.mp4", "kind": "video", "frames": 1500, "gaze_fraction": 0.8},
            "model": {"path": "m.json", "kind": "logistic_regression", "window_s": 10.0, "threshold": 0.6},
            "windows": [], "reading_probability": 0.4, "reading_window_fraction": 0.3,
            "verdict": "not reading",
            "localization": {
                "method": "hmm_edges", "step_s": 1.0, "probability": [0.2, null, 0.9],
                "segments": [{"start_s": 40.0, "end_s": 55.0, "confidence": 0.8}],
                "unscored": [{"start_s": 12.0, "end_s": 19.0, "usable_s": 3.24, "needed_s": 7.0}]
            },
            "clip": null
        }))
        .unwrap();
        let track = Track::new(vec![[0.5, 0.5]; 1500]);
        let page = detection_page(&track, &d, Some("call.mp4"));
        // 12 s of 60 on a 1000-unit timeline: x = 200, width 7 s = 116.7.
        assert!(
            page.contains("<rect class=\"gap\" x=\"200.0\" y=\"0\" width=\"116.7\""),
            "{page}"
        );
        let why = "not enough gaze: 3.2 s usable, 7.0 s needed within one 10 s window";
        assert!(page.contains(&format!("<title>0:12-0:19: {why}</title>")));
        assert!(page.contains(&format!(
            "<h2>Not scored</h2><ul><li><a href=\"#\" onclick=\"seek(12.00);return false\">0:12 - 0:19</a>: {why}</li></ul>"
        )));
        assert!(page.contains("grey: no score"));
        // Written before the window mean was kept: no grey curve, and
        // the legend does not name one.
        assert!(!page.contains("class=\"wmean\"") && !page.contains("grey curve"));
        // With it: one point a second at its middle, broken where there is
        // none; x = 1000 t / 60, y = 100 + (1 - p) 110 for the strip from
        // 100 to 210. Drawn under the smoothed curve.
        let mut kept = d.clone();
        kept.localization.window_mean = vec![Some(0.2), None, Some(0.9)];
        let page = detection_page(&track, &kept, Some("call.mp4"));
        assert!(
            page.contains("<path d=\"M8.3,188.0 M41.7,111.0 \" class=\"wmean\"/><path d=\"M8.3,188.0 M41.7,111.0 \" class=\"prob\"/>"),
            "{page}"
        );
        assert!(page.contains("grey curve: the mean score of the windows"));
        // With the window mean alone the two are one curve: drawn once.
        kept.localization.method = eyereplay_detect::localize::Method::WindowMean;
        let page = detection_page(&track, &kept, Some("call.mp4"));
        assert!(!page.contains("class=\"wmean\"") && !page.contains("grey curve"));
        // The one verdict is an average beside the segment, not a
        // contradiction of it; without segments it is the answer.
        let headline = |page: &str| page.split("<p>").nth(1).unwrap_or("").to_string();
        assert!(
            page.contains(
                "<b>Reading in 1 segment: 0:15 of 1:00</b>. Averaged over the whole recording, \
             P(reading) is 0.400 against the model's threshold 0.600 (not reading on average; \
             the segments say when)."
            ),
            "{page}"
        );
        let mut none = d.clone();
        none.localization.segments.clear();
        let page = detection_page(&track, &none, None);
        assert!(page.contains(
            "<b>No reading segment</b>. Averaged over the whole recording, P(reading) is 0.400 \
             against the model's threshold 0.600: not reading."
        ), "{}", headline(&page));
        d.clip = Some(
            serde_json::from_value(serde_json::json!({
                "start_s": 0.0, "end_s": 8.0, "usable_s": 8.0, "reading_probability": 0.4,
                "low": 0.3, "high": 0.5, "level": 0.9
            }))
            .unwrap(),
        );
        let page = detection_page(&track, &d, None);
        assert!(!page.contains("class=\"gap\"") && !page.contains("Not scored"));
        // Its headline is the clip's verdict with the stretch, score and
        // interval `detect` prints, not "No reading segment" (found by a
        // user audit: a clip called reading whose page said that in bold).
        assert!(
            page.contains(
                "<b>A short clip: not reading</b>. Shorter than one 10 s window, so scored from its \
                 best stretch: 8.0 s of gaze in 0.0-8.0 s scored, P(reading) 0.400, 90 % interval \
                 0.300-0.500, threshold 0.600."
            ),
            "{}",
            headline(&page)
        );
        // 8 s of 60 shaded: x 0, width 133.3; no video, so no "click to play".
        assert!(page.contains("<rect class=\"clip\" x=\"0.0\" y=\"0\" width=\"133.3\""));
        assert!(page.contains("blue: the stretch scored") && !page.contains("click to play"));
        // Its score 0.4 as a line over the stretch, its interval 0.3-0.5 a
        // band: y = 100 + (1 - p) 110 for the strip from 100 to 210.
        assert!(page.contains(
            "<rect class=\"ci\" x=\"0.0\" y=\"155.0\" width=\"133.3\" height=\"22.0\"/>\
             <line class=\"prob\" x1=\"0.0\" x2=\"133.3\" y1=\"166.0\" y2=\"166.0\"/>"
        ));
    }

    /// Labels every 10 s on a minute (six steps, seven labels with 0:00),
    /// every 30 s on 100 s, every 10 min on an hour.
    #[test]
    fn time_ticks_are_at_most_six_steps() {
        assert_eq!(tick_step_s(60.0), 10.0);
        assert_eq!(tick_step_s(100.0), 30.0);
        assert_eq!(tick_step_s(3600.0), 600.0);
        assert_eq!(tick_step_s(3.0), 1.0);
        // Past the table: whole hours, six steps or fewer.
        assert_eq!(tick_step_s(20.0 * 3600.0), 4.0 * 3600.0);
        let page = detection_page(&Track::new(vec![[0.5, 0.5]; 2500]), &sample(), None);
        for label in ["0:00", "0:30", "1:00", "1:30"] {
            assert!(page.contains(&format!(">{label}</span>")), "{label}");
        }
        assert!(!page.contains(">2:00</span>"));
        // 90 s of 100 is not at the edge; an hour's 60:00 is, and ends there.
        assert!(page.contains("<span style=\"left:90.00%\">1:30</span>"));
        let mut hour = sample();
        hour.input.frames = 90_000;
        let page = detection_page(&Track::new(vec![[0.5, 0.5]; 90_000]), &hour, None);
        assert!(page.contains("<span style=\"left:100.00%\" class=\"end\">1:00:00</span>"));
    }

    /// A `#`, `?`, `%` or space in a file name reaches the browser as part
    /// of the path; slashes and the `file://` scheme stay as they are.
    #[test]
    fn the_video_address_is_percent_encoded() {
        assert_eq!(url_path("../Interview #3.mp4"), "../Interview%20%233.mp4");
        assert_eq!(url_path("file:///a/b?c%d.mp4"), "file:///a/b%3Fc%25d.mp4");
        assert_eq!(url_path("plain-name_1.mp4"), "plain-name_1.mp4");
        // UTF-8 bytes one by one, as a browser would send them.
        assert_eq!(url_path("é.mp4"), "%C3%A9.mp4");
        let page = detection_page(
            &Track::new(vec![[0.5, 0.5]; 250]),
            &sample(),
            Some("a #1.mp4"),
        );
        assert!(page.contains("<video id=\"v\" src=\"a%20%231.mp4\""));
    }

    /// A live stream's page says so, not that the input was a gaze file.
    #[test]
    fn a_page_without_video_says_why() {
        let mut d = sample();
        d.input.kind = "live".into();
        let page = detection_page(&Track::new(vec![[0.5, 0.5]; 250]), &d, None);
        assert!(page.contains("A live stream: its video was not kept"));
        assert!(!page.contains("gaze file"));
    }

    fn sample() -> Detection {
        crate::detector::tests::sample_detection()
    }

    #[test]
    fn clock_reads_like_a_player() {
        assert_eq!(clock(0.0), "0:00");
        assert_eq!(clock(61.4), "1:01");
        assert_eq!(clock(3725.0), "1:02:05");
    }
}
