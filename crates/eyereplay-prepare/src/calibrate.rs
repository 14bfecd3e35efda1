//! Stage 2: geometric calibration `c = s (n - 0.5) + mu` per axis (paper
//! eq. 2) and blink filtering (3 x IQR rule, forward fill).

use crate::config::{BlinkFilterConfig, CalibrationConfig, CalibrationMode};
use eyereplay_core::{Canvas, NormPos, Sample, Trajectory};
use eyereplay_signal::{quantile, quartiles};
use serde::{Deserialize, Serialize};

pub use eyereplay_core::Calibration;

/// Auto-scale: the [low, high] percentile range of each axis maps to
/// `fill_fraction` of the canvas extent, centred on the canvas. `None`
/// when an axis has no spread (the scale would be infinite).
pub fn auto_calibration(
    samples: &[NormPos],
    cfg: &CalibrationConfig,
    canvas: Canvas,
) -> Option<(Calibration, [[f64; 2]; 2])> {
    let xs: Vec<f64> = samples.iter().map(|p| p.nx).collect();
    let ys: Vec<f64> = samples.iter().map(|p| p.ny).collect();
    let [w, h] = canvas.extent();
    let axis = |v: &[f64], extent: f64| -> Option<(f64, f64, f64, f64)> {
        let lo = quantile(v, cfg.low_percentile / 100.0)?;
        let hi = quantile(v, cfg.high_percentile / 100.0)?;
        if (hi - lo).is_nan() || hi - lo <= 1e-12 {
            return None;
        }
        let s = cfg.fill_fraction * extent / (hi - lo);
        // Centre: the middle of the percentile range lands mid-canvas.
        let mu = extent / 2.0 - s * ((lo + hi) / 2.0 - 0.5);
        Some((s, mu, lo, hi))
    };
    let (s_x, mu_x, lx, hx) = axis(&xs, w)?;
    let (s_y, mu_y, ly, hy) = axis(&ys, h)?;
    Some((
        Calibration {
            s_x,
            s_y,
            mu_x,
            mu_y,
        },
        [[lx, hx], [ly, hy]],
    ))
}

pub fn manual_calibration(cfg: &CalibrationConfig) -> Option<Calibration> {
    match cfg.mode {
        CalibrationMode::Manual => Some(Calibration {
            s_x: cfg.s_x?,
            s_y: cfg.s_y?,
            mu_x: cfg.mu_x?,
            mu_y: cfg.mu_y?,
        }),
        CalibrationMode::Auto => None,
    }
}

/// How many samples the blink filter replaced, and why.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct FillCounts {
    /// Invalid samples or samples the source marked as blink.
    pub invalid_or_blink: usize,
    /// Valid samples outside the IQR fence on x (only).
    pub outlier_x: usize,
    /// Valid samples outside the IQR fence on y (x inside or also outside).
    pub outlier_y: usize,
    /// Samples replaced in total.
    pub total: usize,
    pub samples: usize,
}

/// Blink filter over all segments of one recording. Per axis, a value outside
/// `[Q1 - k IQR, Q3 + k IQR]` (quartiles over the recording's gaze samples)
/// is an artifact; such samples, and invalid or blink-flagged ones, take the
/// last valid position (forward fill). Samples before the first valid one
/// take the first valid position, since nothing precedes them. Returns the
/// filtered segments (every sample valid, blink flag kept for the renderer)
/// and the counts.
pub fn blink_filter(
    segments: &[Trajectory<NormPos>],
    cfg: &BlinkFilterConfig,
    use_iqr: bool,
) -> (Vec<Trajectory<NormPos>>, FillCounts) {
    let gaze: Vec<NormPos> = segments
        .iter()
        .flat_map(|s| s.samples().iter().filter(|x| x.is_gaze()).map(|x| x.pos))
        .collect();
    let fence = |v: Vec<f64>| -> (f64, f64) {
        if !use_iqr {
            return (f64::NEG_INFINITY, f64::INFINITY);
        }
        let (q1, q3) = quartiles(&v).unwrap_or((f64::NEG_INFINITY, f64::INFINITY));
        let iqr = q3 - q1;
        (q1 - cfg.iqr_k * iqr, q3 + cfg.iqr_k * iqr)
    };
    let fx = fence(gaze.iter().map(|p| p.nx).collect());
    let fy = fence(gaze.iter().map(|p| p.ny).collect());
    let inside = |v: f64, f: (f64, f64)| v >= f.0 && v <= f.1;

    let mut counts = FillCounts::default();
    let first_good = gaze
        .iter()
        .copied()
        .find(|p| inside(p.nx, fx) && inside(p.ny, fy));
    let mut last = first_good.unwrap_or_default();
    let mut out = Vec::with_capacity(segments.len());
    for seg in segments {
        let mut samples = Vec::with_capacity(seg.len());
        for s in seg.samples() {
            counts.samples += 1;
            let mut pos = s.pos;
            if !s.is_gaze() {
                counts.invalid_or_blink += 1;
                pos = last;
            } else {
                let ox = !inside(s.pos.nx, fx);
                let oy = !inside(s.pos.ny, fy);
                if ox && !oy {
                    counts.outlier_x += 1;
                } else if oy {
                    counts.outlier_y += 1;
                }
                if ox || oy {
                    pos = last;
                } else {
                    last = s.pos;
                }
            }
            samples.push(Sample {
                t_s: s.t_s,
                pos,
                valid: true,
                aperture: s.aperture,
                blink: s.blink,
            });
        }
        out.push(Trajectory::new(samples).expect("times were already strictly increasing"));
    }
    counts.total = counts.invalid_or_blink + counts.outlier_x + counts.outlier_y;
    (out, counts)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn auto_scale_maps_percentiles_to_80_percent_centred() {
        // nx uniform on 0.40..0.60 in 101 steps: p5 = 0.41, p95 = 0.59.
        let pts: Vec<NormPos> = (0..=100)
            .map(|i| NormPos {
                nx: 0.40 + 0.002 * i as f64,
                ny: 0.30 + 0.001 * i as f64,
            })
            .collect();
        let (c, ranges) =
            auto_calibration(&pts, &CalibrationConfig::default(), Canvas::default()).unwrap();
        assert!((ranges[0][0] - 0.41).abs() < 1e-12 && (ranges[0][1] - 0.59).abs() < 1e-12);
        // s_x = 0.8 * 1280 / 0.18
        assert!((c.s_x - 0.8 * 1280.0 / 0.18).abs() < 1e-6);
        let lo = c.norm_to_canvas(NormPos {
            nx: 0.41,
            ny: 0.305,
        });
        let hi = c.norm_to_canvas(NormPos {
            nx: 0.59,
            ny: 0.395,
        });
        assert!((lo.x_px - 128.0).abs() < 1e-6 && (hi.x_px - 1152.0).abs() < 1e-6);
        assert!((lo.y_px - 72.0).abs() < 1e-6 && (hi.y_px - 648.0).abs() < 1e-6);
    }

    #[test]
    fn blink_filter_forward_fills_outliers_and_invalid() {
        let mk = |t: f64, nx: f64, valid: bool| Sample {
            t_s: t,
            pos: NormPos { nx, ny: 0.5 },
            valid,
            aperture: None,
            blink: false,
        };
        let mut v = vec![];
        for i in 0..10 {
            v.push(mk(i as f64, 0.50 + 0.01 * (i % 5) as f64, true));
        }
        v[3] = mk(3.0, 5.0, true); // spike far outside 3 IQR
        v[6] = mk(6.0, f64::NAN, false); // tracking loss
        v[0] = mk(0.0, f64::NAN, false); // before any valid sample
        let seg = Trajectory::new(v).unwrap();
        let (out, counts) = blink_filter(&[seg], &BlinkFilterConfig::default(), true);
        let xs: Vec<f64> = out[0].positions().map(|p| p.nx).collect();
        assert_eq!(counts.invalid_or_blink, 2);
        assert_eq!(counts.outlier_x, 1);
        assert_eq!(counts.total, 3);
        assert_eq!(xs[0], 0.51); // back-filled from the first valid sample
        assert_eq!(xs[3], xs[2]);
        assert_eq!(xs[6], xs[5]);
    }
}
