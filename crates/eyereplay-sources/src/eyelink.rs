//! EyeLink ASCII (`edf2asc`) sample lines.
//!
//! Understood: `SAMPLES` lines (which eyes; VEL / RES / INPUT extra columns
//! are skipped by position), sample lines `time x y pupil [x y pupil] ...`
//! with `.` for missing values, `SBLINK`/`EBLINK` events (samples inside a
//! blink are flagged, and so are those of the `ESACC` saccade that holds
//! it), and `MSG ... DISPLAY_COORDS l t r b` for the screen size.
//! Timestamps are tracker milliseconds.

use crate::series::ScreenSeries;
use crate::{EyeChoice, ReadOptions, Recording, ScreenOptions, SourceError};
use std::io::{BufRead, BufReader};
use std::path::Path;

struct RawSample {
    line: u64,
    t_ms: f64,
    left: Option<[f64; 2]>,
    right: Option<[f64; 2]>,
}

pub(crate) fn read(
    path: &Path,
    eye: EyeChoice,
    screen: &ScreenOptions,
    opts: &ReadOptions,
) -> Result<Recording, SourceError> {
    let file = std::fs::File::open(path).map_err(|e| SourceError::io(path, e))?;
    let mut reader = BufReader::new(file);
    // The binary EDF the tracker writes starts "SR_RESEARCH_1000FILE"; read
    // as text it gave "no samples", leaving the user to find out why.
    let head = std::io::BufRead::fill_buf(&mut reader).map_err(|e| SourceError::io(path, e))?;
    if head.starts_with(b"SR_RESEARCH") {
        return Err(SourceError::file(
            path,
            "a binary EDF file; eyereplay reads the ASCII that SR Research's edf2asc \
             writes from it (`edf2asc FILE.edf` gives FILE.asc)",
        ));
    }
    let mut display: Option<[f64; 2]> = None;
    // Eyes of the current recording block: (left, right).
    let mut eyes: Option<(bool, bool)> = None;
    let mut saw_left = false;
    let mut saw_right = false;
    let mut raw: Vec<RawSample> = Vec::new();
    // Blink and saccade intervals per eye: (left?, start_ms, end_ms).
    let mut blinks: Vec<(bool, f64, f64)> = Vec::new();
    let mut saccades: Vec<(bool, f64, f64)> = Vec::new();

    for (i, line) in reader.split(b'\n').enumerate() {
        let line_no = i as u64 + 1;
        let bytes = line.map_err(|e| SourceError::io(path, e))?;
        let text = String::from_utf8_lossy(&bytes);
        let mut tok = text.split_ascii_whitespace();
        let Some(first) = tok.next() else { continue };
        match first {
            "MSG" => {
                let rest: Vec<&str> = tok.collect();
                if let Some(k) = rest.iter().position(|t| *t == "DISPLAY_COORDS") {
                    let nums: Vec<f64> = rest[k + 1..]
                        .iter()
                        .filter_map(|t| t.parse().ok())
                        .collect();
                    if nums.len() == 4 {
                        display = Some([nums[2] - nums[0] + 1.0, nums[3] - nums[1] + 1.0]);
                    }
                }
            }
            "SAMPLES" => {
                let rest: Vec<&str> = tok.collect();
                let l = rest.contains(&"LEFT");
                let r = rest.contains(&"RIGHT");
                // VEL / RES / INPUT columns follow the gaze triplets, which
                // are read by position, so they need no handling.
                saw_left |= l;
                saw_right |= r;
                eyes = Some((l, r));
            }
            "EBLINK" | "ESACC" => {
                let rest: Vec<&str> = tok.collect();
                if rest.len() >= 3 {
                    let is_left = rest[0] == "L";
                    if let (Ok(a), Ok(b)) = (rest[1].parse::<f64>(), rest[2].parse::<f64>()) {
                        let list = if first == "EBLINK" {
                            &mut blinks
                        } else {
                            &mut saccades
                        };
                        list.push((is_left, a, b));
                    }
                }
            }
            // Sample lines start with the timestamp in column 0; indented
            // numbers are continuation lines of calibration messages.
            _ if bytes.first().is_some_and(u8::is_ascii_digit) => {
                let Some((l, r)) = eyes else {
                    // Before any SAMPLES header: not a recording block.
                    continue;
                };
                let t_ms: f64 = first.parse().map_err(|_| {
                    SourceError::line(
                        path,
                        line_no,
                        format!("timestamp {} is not a number", crate::error::cell(first)),
                    )
                })?;
                let fields: Vec<&str> = tok.collect();
                let triplet = |k: usize| -> Result<Option<[f64; 2]>, SourceError> {
                    let (Some(x), Some(y)) = (fields.get(3 * k), fields.get(3 * k + 1)) else {
                        return Err(SourceError::line(
                            path,
                            line_no,
                            "sample line has too few columns",
                        ));
                    };
                    if *x == "." || *y == "." {
                        return Ok(None);
                    }
                    let px = x.parse::<f64>();
                    let py = y.parse::<f64>();
                    match (px, py) {
                        (Ok(a), Ok(b)) => Ok(Some([a, b])),
                        _ => Err(SourceError::line(
                            path,
                            line_no,
                            format!(
                                "gaze {} is not a pair of numbers",
                                crate::error::cell(&format!("{x} {y}"))
                            ),
                        )),
                    }
                };
                let (left, right) = match (l, r) {
                    (true, true) => (triplet(0)?, triplet(1)?),
                    (true, false) => (triplet(0)?, None),
                    (false, true) => (None, triplet(0)?),
                    (false, false) => (None, None),
                };
                raw.push(RawSample {
                    line: line_no,
                    t_ms,
                    left,
                    right,
                });
            }
            _ => {}
        }
    }
    if raw.is_empty() {
        return Err(SourceError::file(
            path,
            "no sample lines: not an EyeLink ASC file with samples",
        ));
    }
    let want_left = match eye {
        EyeChoice::Left => true,
        EyeChoice::Right => false,
        EyeChoice::Mean => saw_left,
    };
    let want_right = match eye {
        EyeChoice::Left => false,
        EyeChoice::Right => true,
        EyeChoice::Mean => saw_right,
    };
    if (eye == EyeChoice::Left && !saw_left) || (eye == EyeChoice::Right && !saw_right) {
        // As the config spells it, and what the file has.
        let (asked, has) = match eye {
            EyeChoice::Left => ("left", "right"),
            _ => ("right", "left"),
        };
        return Err(SourceError::file(
            path,
            format!("eye = \"{asked}\" asked for, but the file records only the {has} eye: use eye = \"{has}\" (or \"mean\")"),
        ));
    }
    let screen_px = screen.screen_px.or(display).ok_or_else(|| {
        SourceError::file(
            path,
            "no DISPLAY_COORDS message; give screen_px = [width, height]",
        )
    })?;
    let ppd = screen.geometry.px_per_deg(screen_px[0]);

    // EyeLink reports each blink inside a saccade: the closing and opening
    // lid drags the pupil's image, so the samples just before SBLINK and
    // just after EBLINK swing far off the screen (y 1408 on a 1024-px
    // display in the bundled both_eyes.asc) though only those between
    // them lose the pupil. The saccade that holds a blink is flagged with
    // it, as SR Research's documentation advises for "blink saccades".
    let held: Vec<(bool, f64, f64)> = saccades
        .iter()
        .filter(|s| {
            blinks
                .iter()
                .any(|b| b.0 == s.0 && s.1 <= b.2 && b.1 <= s.2)
        })
        .copied()
        .collect();
    blinks.extend(held);
    blinks.sort_by(|a, b| a.1.total_cmp(&b.1));
    let in_blink = |t: f64| {
        blinks.iter().any(|&(is_left, a, b)| {
            ((is_left && want_left) || (!is_left && want_right)) && t >= a && t <= b
        })
    };

    let mut series = ScreenSeries::new(path, screen_px, ppd, opts)?;
    for s in raw {
        let l = if want_left { s.left } else { None };
        let r = if want_right { s.right } else { None };
        let g = match (l, r) {
            (Some(a), Some(b)) => Some([(a[0] + b[0]) / 2.0, (a[1] + b[1]) / 2.0]),
            (a, b) => a.or(b),
        };
        series.push(s.line, s.t_ms * 1e-3, g, in_blink(s.t_ms))?;
    }
    series.finish()
}
