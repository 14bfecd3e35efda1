//! Fixation reports (one row per fixation) turned into sample trajectories.
//!
//! Model: the eye holds still at each fixation from its start to its end;
//! after a fixation ends, a saccade carries it to the next fixation in
//! `D = base_ms + ms_per_deg * A` milliseconds, where `A` is the saccade
//! amplitude in degrees (the saccadic main sequence; defaults 21 ms and
//! 2.2 ms/deg after Carpenter, 1988). The position follows a minimum-jerk
//! profile `p0 + (p1 - p0)(10 u^3 - 15 u^4 + 6 u^5)`, `u = t / D`, whose peak
//! velocity `1.875 A / D` lands in the range measured for human saccades. A
//! saccade never outlasts the gap to the next fixation. The eye then waits at
//! the new position until the next fixation starts. Gaps longer than
//! `max_gap_s` (blinks and tracking loss end up there in a fixation report)
//! split the recording rather than being bridged.
//!
//! Samples are synthesized at `synth_rate_hz` (default 1000 Hz) and then
//! travel the same anti-aliased decimation as eye-tracker data, so a saccade
//! looks in the 25 fps output as it would have looked to a fast tracker.
//!
//! `px_per_deg` comes from the geometry, or, with `amplitude_column` given
//! (OneStop / EyeLink reports carry `NEXT_SAC_AMPLITUDE`), is estimated as the
//! median ratio of pixel distance to reported amplitude over saccades of at
//! least 0.5 degrees.

use crate::samples_csv::{column_index, open_table, record_line};
use crate::screen::screen_to_iris;
use crate::series::{parse_f64, recording, SeriesBuilder};
use crate::{file_name, ReadOptions, Recording, RecordingKind, SourceError, SourceSpec};
use eyereplay_core::{NormPos, Sample, ScreenPos};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

pub(crate) fn default_start() -> String {
    "CURRENT_FIX_START".into()
}
pub(crate) fn default_end() -> String {
    "CURRENT_FIX_END".into()
}
pub(crate) fn default_x() -> String {
    "CURRENT_FIX_X".into()
}
pub(crate) fn default_y() -> String {
    "CURRENT_FIX_Y".into()
}

/// Parameters of the saccades synthesized between fixations.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SaccadeModel {
    pub base_ms: f64,
    pub ms_per_deg: f64,
    pub synth_rate_hz: f64,
}

impl Default for SaccadeModel {
    fn default() -> Self {
        SaccadeModel {
            base_ms: 21.0,
            ms_per_deg: 2.2,
            synth_rate_hz: 1000.0,
        }
    }
}

impl SaccadeModel {
    pub fn duration_s(&self, amplitude_deg: f64) -> f64 {
        (self.base_ms + self.ms_per_deg * amplitude_deg) * 1e-3
    }
}

/// Minimum-jerk position fraction at `u` in [0, 1].
pub(crate) fn min_jerk(u: f64) -> f64 {
    let u = u.clamp(0.0, 1.0);
    u * u * u * (10.0 - 15.0 * u + 6.0 * u * u)
}

#[derive(Clone, Copy, Debug)]
struct Fixation {
    line: u64,
    start_s: f64,
    end_s: f64,
    x_px: f64,
    y_px: f64,
    next_amp_deg: Option<f64>,
}

pub(crate) fn read(spec: &SourceSpec, opts: &ReadOptions) -> Result<Vec<Recording>, SourceError> {
    let SourceSpec::Fixations {
        path,
        start_column,
        end_column,
        x_column,
        y_column,
        group_columns,
        amplitude_column,
        time_unit,
        screen_px,
        geometry,
        saccade,
    } = spec
    else {
        unreachable!("fixations::read called with another format");
    };
    let path = path.as_path();
    let (headers, mut rdr) = open_table(path, b',')?;
    let need = |name: &str| {
        column_index(&headers, &[name]).ok_or_else(|| {
            SourceError::file(
                path,
                format!("missing column '{name}' (header: {})", headers.join(",")),
            )
        })
    };
    let (si, ei, xi, yi) = (
        need(start_column)?,
        need(end_column)?,
        need(x_column)?,
        need(y_column)?,
    );
    let gi: Vec<usize> = group_columns
        .iter()
        .map(|g| need(g))
        .collect::<Result<_, _>>()?;
    let ai = amplitude_column.as_deref().map(need).transpose()?;

    // BTreeMap: groups come out in a stable order, so output is deterministic.
    let mut groups: BTreeMap<Vec<String>, Vec<Fixation>> = BTreeMap::new();
    let mut rec = csv::StringRecord::new();
    loop {
        match rdr.read_record(&mut rec) {
            Ok(true) => {}
            Ok(false) => break,
            Err(e) => return Err(SourceError::file(path, e.to_string())),
        }
        let line = record_line(&rec);
        let get = |i: usize| rec.get(i).unwrap_or("");
        let f = Fixation {
            line,
            start_s: time_unit.to_seconds(parse_f64(path, line, start_column, get(si))?),
            end_s: time_unit.to_seconds(parse_f64(path, line, end_column, get(ei))?),
            x_px: parse_f64(path, line, x_column, get(xi))?,
            y_px: parse_f64(path, line, y_column, get(yi))?,
            next_amp_deg: ai.and_then(|i| get(i).trim().parse::<f64>().ok()),
        };
        if f.end_s < f.start_s {
            return Err(SourceError::line(
                path,
                line,
                "fixation ends before it starts",
            ));
        }
        let key: Vec<String> = gi.iter().map(|&i| get(i).trim().to_string()).collect();
        groups.entry(key).or_default().push(f);
    }
    if groups.is_empty() {
        return Err(SourceError::file(path, "no fixation rows"));
    }
    for fixes in groups.values_mut() {
        fixes.sort_by(|a, b| a.start_s.total_cmp(&b.start_s));
    }

    let ppd = match (geometry.px_per_deg, ai) {
        (Some(p), _) => p,
        (None, Some(_)) => estimate_px_per_deg(groups.values())
            .ok_or_else(|| SourceError::file(path, "cannot estimate px_per_deg: no saccade of >= 0.5 deg with an amplitude; give px_per_deg"))?,
        (None, None) => geometry.px_per_deg(screen_px[0]),
    };

    let mut out = Vec::new();
    for (key, fixes) in &groups {
        let mut series = SeriesBuilder::<NormPos>::new(path);
        let dt = 1.0 / saccade.synth_rate_hz;
        let to_iris = |x: f64, y: f64| {
            screen_to_iris(
                ScreenPos { x_px: x, y_px: y },
                *screen_px,
                ppd,
                &opts.eye_gains,
            )
        };
        // Sample times are k * dt on one grid per group, so they never
        // collide and rounding cannot accumulate.
        let t0 = fixes[0].start_s;
        let mut k = 0u64;
        for (i, f) in fixes.iter().enumerate() {
            if i > 0 && f.start_s < fixes[i - 1].end_s {
                return Err(SourceError::line(
                    path,
                    f.line,
                    "fixation starts before the previous one ends",
                ));
            }
            let next = fixes.get(i + 1);
            let span_end = next.map_or(f.end_s, |n| n.start_s);
            loop {
                let t = t0 + k as f64 * dt;
                if t >= span_end && next.is_some() {
                    break;
                }
                if t > span_end {
                    break;
                }
                let pos = match next {
                    Some(n) if t > f.end_s => {
                        let gap = n.start_s - f.end_s;
                        if gap > opts.max_gap_s {
                            // Stay put; the builder splits the gap away.
                            k = ((n.start_s - t0) / dt).ceil() as u64;
                            continue;
                        }
                        let amp_deg = (n.x_px - f.x_px).hypot(n.y_px - f.y_px) / ppd;
                        let d = saccade.duration_s(amp_deg).min(gap);
                        let w = min_jerk((t - f.end_s) / d);
                        to_iris(
                            f.x_px + w * (n.x_px - f.x_px),
                            f.y_px + w * (n.y_px - f.y_px),
                        )
                    }
                    _ => to_iris(f.x_px, f.y_px),
                };
                series.push(f.line, Sample::new(t, pos))?;
                k += 1;
            }
        }
        let segments = series.finish(opts.max_gap_s)?;
        let id = if key.is_empty() {
            file_name(path)
        } else {
            format!("{}#{}", file_name(path), key.join("/"))
        };
        let mut r = recording(path, id, RecordingKind::FixationReport, segments, Some(ppd))?;
        r.rate_hz = saccade.synth_rate_hz;
        out.push(r);
    }
    Ok(out)
}

fn estimate_px_per_deg<'a>(groups: impl Iterator<Item = &'a Vec<Fixation>>) -> Option<f64> {
    let mut ratios = Vec::new();
    for fixes in groups {
        for w in fixes.windows(2) {
            if let Some(a) = w[0].next_amp_deg.filter(|a| *a >= 0.5) {
                let d = (w[1].x_px - w[0].x_px).hypot(w[1].y_px - w[0].y_px);
                ratios.push(d / a);
            }
        }
    }
    if ratios.is_empty() {
        return None;
    }
    ratios.sort_by(|a, b| a.total_cmp(b));
    Some(ratios[ratios.len() / 2])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn min_jerk_endpoints_and_midpoint() {
        assert_eq!(min_jerk(0.0), 0.0);
        assert_eq!(min_jerk(1.0), 1.0);
        assert!((min_jerk(0.5) - 0.5).abs() < 1e-15);
    }

    #[test]
    fn main_sequence_duration_by_hand() {
        // 10 deg: 21 + 22 = 43 ms.
        assert!((SaccadeModel::default().duration_s(10.0) - 0.043).abs() < 1e-12);
    }
}
