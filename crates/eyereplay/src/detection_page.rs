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
    // Gaze: nx (or the trajectory's x) normalized to its 5-95 % range.
    let (lo, hi) = track.x_quantiles_5_95().unwrap_or((0.0, 1.0));
    let mut path = String::new();
    let step = (track.len() / 2000).max(1);
    let mut pen_up = true;
    for (k, p) in track.xy.iter().enumerate().step_by(step) {
        if !p[0].is_finite() {
            pen_up = true;
            continue;
        }
        let y = H_GAZE - 5.0 - (p[0] - lo) / (hi - lo).max(1e-12) * (H_GAZE - 10.0);
        let _ = write!(
            path,
            "{}{:.1},{:.1} ",
            if pen_up { "M" } else { "L" },
            x(k as f64 / FPS),
            y.clamp(0.0, H_GAZE)
        );
        pen_up = false;
    }
    let _ = write!(
        svg,
        "<text x=\"4\" y=\"14\" class=\"lab\">gaze x</text><path d=\"{path}\" class=\"gaze\"/>"
    );
    // Probability per second, the 0.5 line, segments.
    let top = H_GAZE + 10.0;
    let yp = |p: f64| top + (1.0 - p) * H_PROB;
    for g in &d.localization.segments {
        let _ = write!(
            svg,
            "<rect class=\"seg\" x=\"{:.1}\" y=\"0\" width=\"{:.1}\" height=\"{:.1}\" data-start=\"{:.2}\" onclick=\"seek({:.2})\"><title>reading {:.1}-{:.1} s, confidence {:.2}</title></rect>",
            x(g.start_s),
            (x(g.end_s) - x(g.start_s)).max(1.0),
            top + H_PROB,
            g.start_s,
            g.start_s,
            g.start_s,
            g.end_s,
            g.confidence
        );
    }
    let mut prob = String::new();
    let mut pen_up = true;
    for (k, p) in d.localization.probability.iter().enumerate() {
        match p {
            Some(p) => {
                let t = (k as f64 + 0.5) * d.localization.step_s;
                let _ = write!(
                    prob,
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
    let _ = write!(
        svg,
        "<line x1=\"0\" x2=\"{W}\" y1=\"{y:.1}\" y2=\"{y:.1}\" class=\"half\"/><path d=\"{prob}\" class=\"prob\"/><text x=\"4\" y=\"{:.1}\" class=\"lab\">P(reading)</text><line id=\"head\" x1=\"0\" x2=\"0\" y1=\"0\" y2=\"{:.1}\" class=\"head\"/>",
        top + 14.0,
        top + H_PROB,
        y = yp(0.5),
    );
    let segments: String = if d.localization.segments.is_empty() {
        "<li>none</li>".into()
    } else {
        d.localization
            .segments
            .iter()
            .map(|g| {
                format!(
                    "<li><a href=\"#\" onclick=\"seek({:.2});return false\">{} - {}</a> (confidence {:.2})</li>",
                    g.start_s,
                    clock(g.start_s),
                    clock(g.end_s),
                    g.confidence
                )
            })
            .collect()
    };
    let video = match video_href {
        Some(h) => format!(
            "<video id=\"v\" src=\"{}\" controls preload=\"metadata\"></video>",
            esc(h)
        ),
        None => "<p class=\"note\">The input is a gaze file, not a video: the timeline alone.</p>"
            .into(),
    };
    format!(
        "<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\"><title>{title}</title><style>\
body{{font:15px system-ui,sans-serif;margin:24px auto;max-width:1040px;color:#222}}\
video{{width:100%;max-height:480px;background:#000}}svg{{width:100%;height:auto;border:1px solid #ccc;cursor:pointer}}\
.gaze{{fill:none;stroke:#456;stroke-width:1}}.prob{{fill:none;stroke:#c60;stroke-width:2}}\
.half{{stroke:#999;stroke-dasharray:4 4}}.seg{{fill:#fc8;opacity:.45}}.seg:hover{{opacity:.8}}\
.head{{stroke:#d00;stroke-width:2}}.lab{{font-size:12px;fill:#555}}.note{{color:#666}}</style></head><body>\
<h1>{title}</h1><p><b>{when}</b>. The recording as a whole: {verdict} (mean P(reading) {mean:.3} \
against the model's threshold {thr:.3}). Model: {model}.</p>{video}\
<svg id=\"t\" viewBox=\"0 0 {W} {h:.0}\" preserveAspectRatio=\"none\">{svg}</svg>\
<p class=\"note\">0 to {dur}. Orange: reading segments (click to play from there), their ends where the window scores cross half-way between reading and not; curve: P(reading), dashed: P = 0.5.</p>\
<h2>Reading segments</h2><ul>{segments}</ul>\
<script>\
var v=document.getElementById('v'),t=document.getElementById('t'),h=document.getElementById('head'),D={durs:.3};\
function seek(s){{if(v){{v.currentTime=s;v.play();}}}}\
t.addEventListener('click',function(e){{if(e.target.classList.contains('seg'))return;var r=t.getBoundingClientRect();seek((e.clientX-r.left)/r.width*D);}});\
if(v)v.addEventListener('timeupdate',function(){{var x=v.currentTime/D*{W};h.setAttribute('x1',x);h.setAttribute('x2',x);}});\
</script></body></html>\n",
        title = esc(&format!("Reading detection: {}", file_name(&d.input.path))),
        verdict = esc(&d.verdict),
        mean = d.reading_probability,
        thr = d.model.threshold,
        when = esc(&when(d, dur)),
        model = esc(&d.model.path),
        h = top + H_PROB,
        dur = clock(dur),
        durs = dur,
    )
}

/// The headline: how much of the recording is read, in how many segments.
fn when(d: &Detection, dur: f64) -> String {
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

    #[test]
    fn clock_reads_like_a_player() {
        assert_eq!(clock(0.0), "0:00");
        assert_eq!(clock(61.4), "1:01");
        assert_eq!(clock(3725.0), "1:02:05");
    }
}
