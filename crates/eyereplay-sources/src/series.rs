//! Collects samples while a reader parses a file: checks time order with the
//! offending line, then splits into gap-free segments.

use crate::screen::screen_to_iris;
use crate::{file_name, ReadOptions, Recording, RecordingKind, SourceError};
use eyereplay_core::{NormPos, PlanePos, Sample, ScreenPos, Trajectory};
use std::path::{Path, PathBuf};

pub(crate) struct SeriesBuilder<P> {
    path: PathBuf,
    samples: Vec<Sample<P>>,
}

impl<P: PlanePos> SeriesBuilder<P> {
    pub fn new(path: &Path) -> Self {
        SeriesBuilder {
            path: path.to_path_buf(),
            samples: Vec::new(),
        }
    }

    pub fn push(&mut self, line: u64, sample: Sample<P>) -> Result<(), SourceError> {
        if !sample.t_s.is_finite() {
            return Err(SourceError::line(
                &self.path,
                line,
                "timestamp is not a finite number",
            ));
        }
        if let Some(prev) = self.samples.last() {
            if sample.t_s <= prev.t_s {
                return Err(SourceError::line(
                    &self.path,
                    line,
                    format!(
                        "timestamps must increase: {} s follows {} s",
                        fmt_t(sample.t_s),
                        fmt_t(prev.t_s)
                    ),
                ));
            }
        }
        self.samples.push(sample);
        Ok(())
    }

    /// Checks there is usable gaze, then splits at gaps longer than
    /// `max_gap_s`.
    pub fn finish(self, max_gap_s: f64) -> Result<Vec<Trajectory<P>>, SourceError> {
        if self.samples.is_empty() {
            return Err(SourceError::file(&self.path, "no samples (empty file?)"));
        }
        if !self.samples.iter().any(|s| s.is_gaze()) {
            return Err(SourceError::file(
                &self.path,
                format!(
                    "every one of {} samples is invalid or in a blink: no usable gaze",
                    self.samples.len()
                ),
            ));
        }
        let mut segments = Vec::new();
        let mut current: Vec<Sample<P>> = Vec::new();
        for s in self.samples {
            if let Some(prev) = current.last() {
                if s.t_s - prev.t_s > max_gap_s {
                    push_segment(&mut segments, std::mem::take(&mut current))?;
                }
            }
            current.push(s);
        }
        push_segment(&mut segments, current)?;
        Ok(segments)
    }
}

/// Keeps a segment only if it carries gaze: a block that is all blink or
/// tracking loss has nothing to resample.
fn push_segment<P: PlanePos>(
    out: &mut Vec<Trajectory<P>>,
    samples: Vec<Sample<P>>,
) -> Result<(), SourceError> {
    if samples.iter().filter(|s| s.is_gaze()).count() >= 2 {
        out.push(Trajectory::new(samples)?);
    }
    Ok(())
}

fn fmt_t(t: f64) -> String {
    format!("{t:.6}")
        .trim_end_matches('0')
        .trim_end_matches('.')
        .to_string()
}

/// What a source with fewer than 2 gaze samples in any segment is told.
pub const NO_GAZE_SEGMENT: &str = "no segment with at least 2 gaze samples";

/// Assembles a [`Recording`] from segments, with the median rate measured.
pub(crate) fn recording(
    path: &Path,
    id: String,
    kind: RecordingKind,
    segments: Vec<Trajectory<NormPos>>,
    px_per_deg: Option<f64>,
) -> Result<Recording, SourceError> {
    if segments.is_empty() {
        return Err(SourceError::file(path, NO_GAZE_SEGMENT));
    }
    let mut dts: Vec<f64> = segments
        .iter()
        .flat_map(|s| {
            s.samples()
                .windows(2)
                .map(|w| w[1].t_s - w[0].t_s)
                .collect::<Vec<_>>()
        })
        .collect();
    let mid = dts.len() / 2;
    let dt = *dts.select_nth_unstable_by(mid, |a, b| a.total_cmp(b)).1;
    Ok(Recording {
        id,
        path: path.to_path_buf(),
        kind,
        rate_hz: 1.0 / dt,
        segments,
        px_per_deg,
    })
}

/// Parses a numeric cell, naming file, line and column on failure.
/// A coordinate cell that records tracking loss rather than a number: empty,
/// NaN (Python, MATLAB), `NA` (R's `write.csv`), `n/a` (BIDS), `.` (SAS,
/// EyeLink's `edf2asc`), `null` or `None` (JSON and pandas' object
/// columns written as text). Such a sample is a gap, not a format error.
pub(crate) fn is_missing(cell: &str) -> bool {
    let c = cell.trim();
    c.is_empty()
        || c == "."
        || ["nan", "na", "n/a", "null", "none"]
            .iter()
            .any(|m| c.eq_ignore_ascii_case(m))
}

pub(crate) fn parse_f64(
    path: &Path,
    line: u64,
    column: &str,
    cell: &str,
) -> Result<f64, SourceError> {
    let c = cell.trim();
    c.parse::<f64>().map_err(|_| {
        SourceError::line(
            path,
            line,
            format!(
                "column '{column}': {} is not a number",
                crate::error::cell(c)
            ),
        )
    })
}

/// Eye trackers record at 25-2000 samples a second; timestamps read in the
/// wrong unit put them a thousand times too close or too far apart. Read
/// as seconds where they were milliseconds, every sample became a segment
/// of its own ("no segment with at least 2 gaze samples"); the other way,
/// the whole recording lasted a few milliseconds and did not seem to move
/// ("set calibration.mode = manual", wrong advice). Said here instead, by
/// the median step between samples.
const SAMPLE_RATE_HZ: (f64, f64) = (1.0, 10_000.0);

fn check_sample_rate<P>(path: &Path, samples: &[Sample<P>]) -> Result<(), SourceError> {
    let mut steps: Vec<f64> = samples
        .windows(2)
        .map(|w| w[1].t_s - w[0].t_s)
        .filter(|d| *d > 0.0)
        .collect();
    if steps.len() < 2 {
        return Ok(());
    }
    steps.sort_by(f64::total_cmp);
    let step_s = steps[steps.len() / 2];
    let rate_hz = 1.0 / step_s;
    let (lo, hi) = SAMPLE_RATE_HZ;
    if (lo..=hi).contains(&rate_hz) {
        return Ok(());
    }
    Err(SourceError::file(
        path,
        format!(
            "its timestamps put the samples {step_s:.3e} s apart ({rate_hz:.3e} a second; eye trackers record \
             {lo}-{hi} a second): is the time unit what the config (time_unit) or its sidecar says? \
             In a unit a thousand times {} they would come {:.0} a second",
            if rate_hz > hi {
                "larger (s for ms, ms for us)"
            } else {
                "smaller (ms for s, us for ms)"
            },
            if rate_hz > hi { rate_hz / 1000.0 } else { rate_hz * 1000.0 }
        ),
    ))
}

/// Checks that a screen-pixel source's geometry gives finite positions.
pub(crate) fn check_screen(
    path: &Path,
    screen_px: [f64; 2],
    px_per_deg: f64,
) -> Result<(), SourceError> {
    let positive = |v: f64| v.is_finite() && v > 0.0;
    if !(positive(screen_px[0]) && positive(screen_px[1])) {
        return Err(SourceError::file(
            path,
            format!(
                "screen size {} x {} px is not positive (screen_px, DISPLAY_COORDS or ScreenResolution)",
                screen_px[0], screen_px[1]
            ),
        ));
    }
    if !positive(px_per_deg) {
        return Err(SourceError::file(
            path,
            format!(
                "{px_per_deg} px per degree is not a positive number (check px_per_deg, screen width and viewing distance)"
            ),
        ));
    }
    Ok(())
}

/// Collects eye-tracker samples in screen pixels, converting each to a
/// normalized iris position (see [`crate::screen`]).
pub(crate) struct ScreenSeries<'a> {
    series: SeriesBuilder<NormPos>,
    path: &'a Path,
    screen_px: [f64; 2],
    px_per_deg: f64,
    opts: &'a ReadOptions,
    /// Gaze samples (not lost, not in a blink), and the range they span,
    /// for the check that they were recorded on `screen_px`.
    gaze_n: usize,
    far_outside_n: usize,
    x_range_px: [f64; 2],
    y_range_px: [f64; 2],
}

/// Share of gaze samples that may lie more than a quarter of the screen
/// beyond its edges before `screen_px` is taken for the wrong screen. Eye
/// trackers do report gaze off the screen (a glance at the keyboard, a
/// head turned), but not for most of a recording.
const MAX_FAR_OUTSIDE_FRACTION: f64 = 0.5;

impl<'a> ScreenSeries<'a> {
    /// Fails when the screen size or `px_per_deg` is not a positive finite
    /// number (a zero-width DISPLAY_COORDS, an absurd ScreenDistance), which
    /// would turn every position into infinity.
    pub fn new(
        path: &'a Path,
        screen_px: [f64; 2],
        px_per_deg: f64,
        opts: &'a ReadOptions,
    ) -> Result<Self, SourceError> {
        check_screen(path, screen_px, px_per_deg)?;
        Ok(ScreenSeries {
            series: SeriesBuilder::new(path),
            path,
            screen_px,
            px_per_deg,
            opts,
            gaze_n: 0,
            far_outside_n: 0,
            x_range_px: [f64::INFINITY, f64::NEG_INFINITY],
            y_range_px: [f64::INFINITY, f64::NEG_INFINITY],
        })
    }

    /// `gaze` is `None` for tracking loss.
    pub fn push(
        &mut self,
        line: u64,
        t_s: f64,
        gaze: Option<[f64; 2]>,
        blink: bool,
    ) -> Result<(), SourceError> {
        let [x_px, y_px] = gaze.unwrap_or([f64::NAN, f64::NAN]);
        if gaze.is_some() && !blink && x_px.is_finite() && y_px.is_finite() {
            let [w, h] = self.screen_px;
            self.gaze_n += 1;
            if x_px < -0.25 * w || x_px > 1.25 * w || y_px < -0.25 * h || y_px > 1.25 * h {
                self.far_outside_n += 1;
            }
            self.x_range_px = [self.x_range_px[0].min(x_px), self.x_range_px[1].max(x_px)];
            self.y_range_px = [self.y_range_px[0].min(y_px), self.y_range_px[1].max(y_px)];
        }
        let pos = screen_to_iris(
            ScreenPos { x_px, y_px },
            self.screen_px,
            self.px_per_deg,
            &self.opts.eye_gains,
        );
        self.series.push(
            line,
            Sample {
                t_s,
                pos,
                valid: gaze.is_some(),
                aperture: None,
                blink,
            },
        )
    }

    pub fn finish(self) -> Result<Recording, SourceError> {
        check_sample_rate(self.path, &self.series.samples)?;
        self.check_on_screen()?;
        let segments = self.series.finish(self.opts.max_gap_s)?;
        recording(
            self.path,
            file_name(self.path),
            RecordingKind::EyeTracker,
            segments,
            Some(self.px_per_deg),
        )
    }
}

impl ScreenSeries<'_> {
    /// Gaze recorded on another screen than `screen_px` says, or written
    /// as fractions of the screen (Pupil Labs' `norm_pos`, Tobii's
    /// normalized columns), would be read as movements of the wrong size
    /// (every fixation in a 1 px corner, for fractions) without a word.
    fn check_on_screen(&self) -> Result<(), SourceError> {
        if self.gaze_n < 2 {
            return Ok(());
        }
        let [w, h] = self.screen_px;
        let range = format!(
            "x {:.1} to {:.1}, y {:.1} to {:.1}",
            self.x_range_px[0], self.x_range_px[1], self.y_range_px[0], self.y_range_px[1]
        );
        let spans_fraction = self.x_range_px[0] >= -0.5
            && self.x_range_px[1] <= 1.5
            && self.y_range_px[0] >= -0.5
            && self.y_range_px[1] <= 1.5;
        if spans_fraction && w.min(h) >= 100.0 {
            return Err(SourceError::file(
                self.path,
                format!(
                    "every gaze sample lies within 0-1 ({range}) on a {w}x{h} px screen: \
                     fractions of the screen, not pixels? Multiply x by the width and y by \
                     the height (eyereplay reads pixels)"
                ),
            ));
        }
        let far = self.far_outside_n as f64 / self.gaze_n as f64;
        if far > MAX_FAR_OUTSIDE_FRACTION {
            return Err(SourceError::file(
                self.path,
                format!(
                    "{:.0} % of the gaze samples lie over a quarter of the screen beyond the \
                     {w}x{h} px screen ({range}): is screen_px the screen they were recorded on?",
                    100.0 * far
                ),
            ));
        }
        Ok(())
    }
}

/// Calls `f` with each record of a CSV reader and its line number; a
/// malformed record is an error naming the file.
pub(crate) fn for_each_record<R: std::io::Read>(
    path: &Path,
    rdr: &mut csv::Reader<R>,
    mut f: impl FnMut(&csv::StringRecord, u64) -> Result<(), SourceError>,
) -> Result<(), SourceError> {
    let mut rec = csv::StringRecord::new();
    loop {
        match rdr.read_record(&mut rec) {
            Ok(true) => f(&rec, rec.position().map(|p| p.line()).unwrap_or(0))?,
            Ok(false) => return Ok(()),
            Err(e) => return Err(SourceError::file(path, e.to_string())),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(step_s: f64) -> Vec<Sample<NormPos>> {
        (0..100)
            .map(|k| Sample {
                t_s: 10.0 + k as f64 * step_s,
                pos: NormPos { nx: 0.5, ny: 0.5 },
                valid: true,
                aperture: None,
                blink: false,
            })
            .collect()
    }

    /// 500 samples a second read in the right unit pass; read a thousand
    /// times too close (seconds taken as milliseconds) or too far apart
    /// (the other way) they are refused, with the rate the other unit
    /// gives: 1 / 0.002 s = 500.
    #[test]
    fn a_sample_rate_no_eye_tracker_records_says_the_unit_is_wrong() {
        let p = Path::new("gaze.csv");
        assert!(check_sample_rate(p, &at(0.002)).is_ok());
        assert!(check_sample_rate(p, &at(1.0 / 30.0)).is_ok());
        let close = check_sample_rate(p, &at(2e-6)).unwrap_err().to_string();
        assert!(
            close.starts_with("gaze.csv: its timestamps put the samples 2.000e-6 s apart")
                && close.contains("a thousand times larger")
                && close.ends_with("they would come 500 a second"),
            "{close}"
        );
        let far = check_sample_rate(p, &at(2.0)).unwrap_err().to_string();
        assert!(
            far.contains("a thousand times smaller")
                && far.ends_with("they would come 500 a second"),
            "{far}"
        );
        // Too few steps to tell: no verdict.
        assert!(check_sample_rate(p, &at(5.0)[..2]).is_ok());
    }
}
