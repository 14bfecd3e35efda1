//! Agreement with a reference extraction (MediaPipe Python's face mesh, as
//! written by `scripts/dev/mediapipe_ref.py`): detection rate, Pearson r per
//! axis over frames where both see open eyes, median and p95 |difference|.

use crate::error::{ExtractError, Result};
use crate::output::Row;
use std::path::Path;

/// Per-frame values of one extraction, for comparison.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Series {
    pub time_s: Vec<f64>,
    /// Mean of both eyes, `None` without a face.
    pub n: Vec<Option<(f64, f64)>>,
    /// Mean aperture, `None` without a face.
    pub aperture: Vec<Option<f64>>,
}

impl Series {
    pub fn from_rows(rows: &[Row]) -> Series {
        Series {
            time_s: rows.iter().map(|r| r.time_s).collect(),
            n: rows.iter().map(|r| r.mean_n()).collect(),
            aperture: rows.iter().map(|r| r.aperture()).collect(),
        }
    }

    /// Reads the reference CSV (`frame,time_s,detected,nx_l,ny_l,nx_r,ny_r,
    /// aperture_l,aperture_r`; empty fields without a face).
    pub fn read_reference(path: &Path) -> Result<Series> {
        let bad = |line: u64, message: String| ExtractError::Reference {
            path: path.to_path_buf(),
            line,
            message,
        };
        let text = std::fs::read_to_string(path).map_err(|e| ExtractError::Io {
            path: path.to_path_buf(),
            source: e,
        })?;
        let mut lines = text.lines();
        let header = lines.next().ok_or_else(|| bad(1, "empty file".into()))?;
        let cols: Vec<&str> = header.split(',').collect();
        let want = [
            "frame",
            "time_s",
            "detected",
            "nx_l",
            "ny_l",
            "nx_r",
            "ny_r",
            "aperture_l",
            "aperture_r",
        ];
        if cols != want {
            return Err(bad(1, format!("header must be {}", want.join(","))));
        }
        let mut s = Series::default();
        for (i, line) in lines.enumerate() {
            let ln = i as u64 + 2;
            let f: Vec<&str> = line.split(',').collect();
            if f.len() != want.len() {
                return Err(bad(
                    ln,
                    format!("{} fields, expected {}", f.len(), want.len()),
                ));
            }
            let num = |k: usize| -> Result<f64> {
                f[k].parse::<f64>()
                    .map_err(|e| bad(ln, format!("{}: {e}", want[k])))
            };
            if num(0)? as usize != s.time_s.len() {
                return Err(bad(ln, "frames must be numbered 0, 1, 2, ...".into()));
            }
            s.time_s.push(num(1)?);
            if f[2] == "1" {
                let (nxl, nyl, nxr, nyr, apl, apr) =
                    (num(3)?, num(4)?, num(5)?, num(6)?, num(7)?, num(8)?);
                s.n.push(Some(((nxl + nxr) / 2.0, (nyl + nyr) / 2.0)));
                s.aperture.push(Some((apl + apr) / 2.0));
            } else {
                s.n.push(None);
                s.aperture.push(None);
            }
        }
        Ok(s)
    }

    pub fn detection_rate(&self) -> f64 {
        self.n.iter().filter(|v| v.is_some()).count() as f64 / self.n.len().max(1) as f64
    }

    /// Frames whose eyes are open: the same rule as [`crate::flag_blinks`]
    /// (mean aperture >= ratio x median, and not next to a closed frame).
    pub fn open_eyes(&self, ratio: f64) -> Vec<bool> {
        let mut rows: Vec<Row> = self
            .aperture
            .iter()
            .zip(&self.n)
            .map(|(a, n)| Row::synthetic(a.zip(*n)))
            .collect();
        crate::output::flag_blinks(&mut rows, ratio);
        rows.iter().map(|r| r.valid()).collect()
    }
}

/// The agreement numbers.
#[derive(Clone, Debug, PartialEq)]
pub struct Agreement {
    pub frames: usize,
    pub detection_rate: f64,
    pub reference_detection_rate: f64,
    /// Frames where both have a face with open eyes.
    pub open_frames: usize,
    pub r_x: f64,
    pub r_y: f64,
    pub median_abs_dx: f64,
    pub p95_abs_dx: f64,
    pub median_abs_dy: f64,
    pub p95_abs_dy: f64,
    /// Largest |time difference| between paired frames (checks the decoders
    /// agree on which frame is which).
    pub max_time_diff_s: f64,
}

pub fn pearson(a: &[f64], b: &[f64]) -> f64 {
    eyereplay_signal::pearson(a, b).unwrap_or(f64::NAN)
}

/// Quantile `q` in [0, 1] of unsorted values (numpy's linear method, the
/// one convention of [`eyereplay_signal::stats`]); NaN when empty.
pub fn percentile(v: &[f64], q: f64) -> f64 {
    eyereplay_signal::quantile(v, q).unwrap_or(f64::NAN)
}

/// Compares `ours` with `reference` frame by frame (paired by index).
pub fn compare(ours: &Series, reference: &Series, blink_ratio: f64) -> Agreement {
    let n = ours.n.len().min(reference.n.len());
    let open_a = ours.open_eyes(blink_ratio);
    let open_b = reference.open_eyes(blink_ratio);
    let (mut xa, mut xb, mut ya, mut yb) = (vec![], vec![], vec![], vec![]);
    let mut max_dt: f64 = 0.0;
    for i in 0..n {
        max_dt = max_dt.max((ours.time_s[i] - reference.time_s[i]).abs());
        if let (true, true, Some(a), Some(b)) = (open_a[i], open_b[i], ours.n[i], reference.n[i]) {
            xa.push(a.0);
            xb.push(b.0);
            ya.push(a.1);
            yb.push(b.1);
        }
    }
    let dx: Vec<f64> = xa.iter().zip(&xb).map(|(a, b)| (a - b).abs()).collect();
    let dy: Vec<f64> = ya.iter().zip(&yb).map(|(a, b)| (a - b).abs()).collect();
    Agreement {
        frames: n,
        detection_rate: ours.detection_rate(),
        reference_detection_rate: reference.detection_rate(),
        open_frames: xa.len(),
        r_x: pearson(&xa, &xb),
        r_y: pearson(&ya, &yb),
        median_abs_dx: percentile(&dx, 0.5),
        p95_abs_dx: percentile(&dx, 0.95),
        median_abs_dy: percentile(&dy, 0.5),
        p95_abs_dy: percentile(&dy, 0.95),
        max_time_diff_s: max_dt,
    }
}

impl std::fmt::Display for Agreement {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "frames {}  detection {:.2}% (reference {:.2}%)  open-eye frames {}\n\
             r_x {:.3}  r_y {:.3}\n\
             |dx| median {:.4} p95 {:.4}   |dy| median {:.4} p95 {:.4}   max |dt| {:.4} s",
            self.frames,
            100.0 * self.detection_rate,
            100.0 * self.reference_detection_rate,
            self.open_frames,
            self.r_x,
            self.r_y,
            self.median_abs_dx,
            self.p95_abs_dx,
            self.median_abs_dy,
            self.p95_abs_dy,
            self.max_time_diff_s
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pearson_and_percentile_match_hand_values() {
        assert!((pearson(&[1.0, 2.0, 3.0], &[2.0, 4.0, 6.0]) - 1.0).abs() < 1e-12);
        assert!((pearson(&[1.0, 2.0, 3.0], &[3.0, 2.0, 1.0]) + 1.0).abs() < 1e-12);
        // x = 1,2,3,4; y = 1,3,2,4: cov 2.0/ (var 1.25 each * 4) -> r = 0.8
        assert!((pearson(&[1.0, 2.0, 3.0, 4.0], &[1.0, 3.0, 2.0, 4.0]) - 0.8).abs() < 1e-12);
        assert_eq!(percentile(&[4.0, 1.0, 3.0, 2.0], 0.5), 2.5);
        assert_eq!(percentile(&[0.0, 10.0], 0.95), 9.5);
    }
}
