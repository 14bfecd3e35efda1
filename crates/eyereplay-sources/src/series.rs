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
}

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
