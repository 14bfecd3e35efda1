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
//! Real fixations are not still: the eye drifts. During each fixation the
//! position follows a random walk (Brownian motion) with diffusion
//! coefficient `drift_deg2_per_s` (default 0.0056 deg^2/s, i.e. 20 arcmin^2/s,
//! the order reported for fixational drift), starting at the reported
//! fixation position; the saccade leaves from wherever the drift ended. At
//! 25 fps that is about 0.02 degrees of movement per frame, the same order as
//! the residual landmark jitter of smoothed webcam sources, so the two kinds
//! of recording do not differ in stillness alone. Drift is seeded by the
//! dataset seed and the recording id (deterministic); 0 turns it off.
//!
//! Samples are synthesized at `synth_rate_hz` (default 1000 Hz) and then
//! travel the same anti-aliased decimation as eye-tracker data, so a saccade
//! looks in the 25 fps output as it would have looked to a fast tracker.
//!
//! `px_per_deg` comes from the geometry, or, with `amplitude_column` given
//! (OneStop / EyeLink reports carry `NEXT_SAC_AMPLITUDE`), is estimated as the
//! median ratio of pixel distance to reported amplitude over saccades of at
//! least 0.5 degrees.

use crate::samples_csv::{column_index, open_table};
use crate::screen::screen_to_iris;
use crate::series::{for_each_record, parse_f64, recording, SeriesBuilder};
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
    /// Fixational drift diffusion coefficient (deg^2/s); 0 = still fixations.
    pub drift_deg2_per_s: f64,
}

impl Default for SaccadeModel {
    fn default() -> Self {
        SaccadeModel {
            base_ms: 21.0,
            ms_per_deg: 2.2,
            synth_rate_hz: 1000.0,
            drift_deg2_per_s: 0.0056,
        }
    }
}

impl SaccadeModel {
    /// Rejects settings that cannot make samples: a rate outside (0, 100 kHz]
    /// (above that, memory runs out before the file does), negative or
    /// non-finite durations or drift.
    /// The message is one line, without a file ([`SourceError::Saccade`]).
    pub fn check(&self) -> Result<(), SourceError> {
        if !(self.synth_rate_hz > 0.0 && self.synth_rate_hz <= 1e5) {
            return Err(SourceError::Saccade(format!(
                "saccade.synth_rate_hz = {} must be in (0, 100000]",
                self.synth_rate_hz
            )));
        }
        for (k, v) in [
            ("base_ms", self.base_ms),
            ("ms_per_deg", self.ms_per_deg),
            ("drift_deg2_per_s", self.drift_deg2_per_s),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(SourceError::Saccade(format!(
                    "saccade.{k} = {v} must be a finite number >= 0"
                )));
            }
        }
        Ok(())
    }

    pub fn duration_s(&self, amplitude_deg: f64) -> f64 {
        (self.base_ms + self.ms_per_deg * amplitude_deg) * 1e-3
    }
}

/// Longest fixation accepted, s.
const MAX_FIXATION_S: f64 = 60.0;

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
    saccade
        .check()
        .map_err(|e| SourceError::file(path, e.to_string()))?;
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
    for_each_record(path, &mut rdr, |rec, line| {
        let get = |i: usize| rec.get(i).unwrap_or("");
        let f = Fixation {
            line,
            start_s: time_unit.to_seconds(parse_f64(path, line, start_column, get(si))?),
            end_s: time_unit.to_seconds(parse_f64(path, line, end_column, get(ei))?),
            x_px: parse_f64(path, line, x_column, get(xi))?,
            y_px: parse_f64(path, line, y_column, get(yi))?,
            next_amp_deg: ai.and_then(|i| get(i).trim().parse::<f64>().ok()),
        };
        if ![f.start_s, f.end_s, f.x_px, f.y_px]
            .iter()
            .all(|v| v.is_finite())
        {
            return Err(SourceError::line(
                path,
                line,
                "fixation start, end, x and y must be finite numbers",
            ));
        }
        if f.end_s < f.start_s {
            return Err(SourceError::line(
                path,
                line,
                "fixation ends before it starts",
            ));
        }
        // Samples are synthesized at synth_rate_hz over the fixation: an
        // absurd duration would fill memory instead of failing. Real
        // fixations last well under a few seconds; this catches a wrong
        // time_unit too.
        if f.end_s - f.start_s > MAX_FIXATION_S {
            return Err(SourceError::line(
                path,
                line,
                format!(
                    "fixation lasts {:.0} s, more than {MAX_FIXATION_S} s: not a fixation (check time_unit, {time_unit:?} here)",
                    f.end_s - f.start_s
                ),
            ));
        }
        let key: Vec<String> = gi.iter().map(|&i| get(i).trim().to_string()).collect();
        groups.entry(key).or_default().push(f);
        Ok(())
    })?;
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

    crate::series::check_screen(path, *screen_px, ppd)?;
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
        let id = if key.is_empty() {
            file_name(path)
        } else {
            format!("{}#{}", file_name(path), key.join("/"))
        };
        let mut drift = Drift::new(opts.seed, &id, saccade.drift_deg2_per_s, dt, ppd);
        // Sample times are k * dt on one grid per group, so they never
        // collide and rounding cannot accumulate.
        let t0 = fixes[0].start_s;
        let mut k = 0u64;
        for (i, f) in fixes.iter().enumerate() {
            if i > 0 && f.start_s < fixes[i - 1].end_s {
                // Both rows, in time order (the file's order may differ),
                // and the likely cause where nothing groups the rows: a
                // file of several trials whose clocks start again.
                let prev = &fixes[i - 1];
                let hint = if key.is_empty() {
                    "; several recordings in one file, each clock starting again? group them with \
                     group_columns, e.g. [\"participant_id\", \"TRIAL_INDEX\"]"
                } else {
                    ""
                };
                return Err(SourceError::line(
                    path,
                    f.line,
                    format!(
                        "fixation starts at {:.3} s, before the one of line {} ends ({:.3} s){hint}",
                        f.start_s, prev.line, prev.end_s
                    ),
                ));
            }
            let next = fixes.get(i + 1);
            let span_end = next.map_or(f.end_s, |n| n.start_s);
            // Where the eye is while it fixates: the report's position plus drift.
            let mut here = [f.x_px, f.y_px];
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
                        let amp_deg = (n.x_px - here[0]).hypot(n.y_px - here[1]) / ppd;
                        let d = saccade.duration_s(amp_deg).min(gap);
                        let w = min_jerk((t - f.end_s) / d);
                        to_iris(
                            here[0] + w * (n.x_px - here[0]),
                            here[1] + w * (n.y_px - here[1]),
                        )
                    }
                    _ => {
                        if t > f.start_s {
                            drift.step(&mut here);
                        }
                        to_iris(here[0], here[1])
                    }
                };
                series.push(f.line, Sample::new(t, pos))?;
                k += 1;
            }
        }
        let segments = series.finish(opts.max_gap_s)?;
        let mut r = recording(path, id, RecordingKind::FixationReport, segments, Some(ppd))?;
        r.rate_hz = saccade.synth_rate_hz;
        out.push(r);
    }
    Ok(out)
}

/// Brownian fixational drift in screen pixels.
struct Drift {
    rng: rand_chacha::ChaCha8Rng,
    /// Per-axis standard deviation of one sample step, px.
    step_px: f64,
}

impl Drift {
    fn new(seed: u64, id: &str, d_deg2_per_s: f64, dt_s: f64, px_per_deg: f64) -> Self {
        use rand::SeedableRng;
        use sha2::{Digest, Sha256};
        // One stream per recording, stable across runs and platforms.
        let h = Sha256::digest(format!("{seed}/{id}").as_bytes());
        let mut key = [0u8; 32];
        key.copy_from_slice(&h);
        Drift {
            rng: rand_chacha::ChaCha8Rng::from_seed(key),
            // 2-D Brownian motion: per-axis variance 2 D dt.
            step_px: (2.0 * d_deg2_per_s * dt_s).sqrt() * px_per_deg,
        }
    }

    fn step(&mut self, p: &mut [f64; 2]) {
        if self.step_px > 0.0 {
            use rand_distr::{Distribution, StandardNormal};
            let a: f64 = StandardNormal.sample(&mut self.rng);
            let b: f64 = StandardNormal.sample(&mut self.rng);
            p[0] += self.step_px * a;
            p[1] += self.step_px * b;
        }
    }
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
    fn drift_diffuses_at_the_set_rate() {
        // Mean squared displacement after time T: 4 D T (2-D).
        let (d, dt, ppd) = (0.0056, 0.001, 50.0);
        let n_walks = 400;
        let steps = 500; // 0.5 s
        let mut msd = 0.0;
        for w in 0..n_walks {
            let mut dr = Drift::new(1, &format!("w{w}"), d, dt, ppd);
            let mut p = [0.0, 0.0];
            for _ in 0..steps {
                dr.step(&mut p);
            }
            msd += (p[0] * p[0] + p[1] * p[1]) / (ppd * ppd);
        }
        msd /= n_walks as f64;
        let want = 4.0 * d * steps as f64 * dt;
        assert!((msd / want - 1.0).abs() < 0.15, "{msd} vs {want}");
        // Same seed and id: same walk.
        let mut a = Drift::new(3, "x", d, dt, ppd);
        let mut b = Drift::new(3, "x", d, dt, ppd);
        let (mut pa, mut pb) = ([0.0; 2], [0.0; 2]);
        a.step(&mut pa);
        b.step(&mut pb);
        assert_eq!(pa, pb);
    }

    #[test]
    fn main_sequence_duration_by_hand() {
        // 10 deg: 21 + 22 = 43 ms.
        assert!((SaccadeModel::default().duration_s(10.0) - 0.043).abs() < 1e-12);
    }

    #[test]
    fn saccade_settings_that_cannot_make_samples_are_rejected() {
        assert!(SaccadeModel::default().check().is_ok());
        for bad in [
            SaccadeModel {
                synth_rate_hz: 1e12,
                ..Default::default()
            },
            SaccadeModel {
                synth_rate_hz: f64::NAN,
                ..Default::default()
            },
            SaccadeModel {
                drift_deg2_per_s: -1.0,
                ..Default::default()
            },
        ] {
            assert!(bad.check().is_err(), "{bad:?}");
        }
    }
}
