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
    /// Invalid samples or samples the source marked as blink (both axes
    /// replaced).
    pub invalid_or_blink: usize,
    /// Valid samples whose x lay outside the IQR fence on x (x replaced,
    /// whatever y did).
    pub outlier_x: usize,
    /// Valid samples whose y lay outside the IQR fence on y (y replaced,
    /// whatever x did).
    pub outlier_y: usize,
    /// Samples with at least one axis replaced. A valid sample outside both
    /// fences counts once here and once in each of `outlier_x`, `outlier_y`.
    pub total: usize,
    pub samples: usize,
}

/// What the blink filter replaces when one axis of a valid sample is outside
/// its fence.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FillAxes {
    /// Only that axis (the paper's rule, and the default).
    #[default]
    PerAxis,
    /// Both axes, from the last sample good on both. On the real webcam
    /// extractions a glitch on one axis usually comes with an error on the
    /// other that stays inside its fence (docs/PIPELINE.md, "Blink
    /// filtering"), which this keeps out.
    Joint,
}

/// Blink filter over all segments of one recording. Per axis, a value outside
/// `[Q1 - k IQR, Q3 + k IQR]` (quartiles over the recording's gaze samples)
/// is an artifact and takes that axis's last good value (forward fill); the
/// other axis keeps its own value when it is inside its fence (the paper's
/// rule is per axis: a landmark glitch on x says nothing about y). Invalid or
/// blink-flagged samples take the last good value on both axes. Values before
/// the first good one on an axis take that axis's first good value, since
/// nothing precedes them. With [`FillAxes::Joint`] a sample with either axis
/// outside takes the last sample good on both. Returns the filtered segments
/// (every sample valid, blink flag kept for the renderer) and the counts.
pub fn blink_filter(
    segments: &[Trajectory<NormPos>],
    cfg: &BlinkFilterConfig,
    use_iqr: bool,
    axes: FillAxes,
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
    // The last good value per axis, seeded with the first good one.
    let first_good = |get: fn(&NormPos) -> f64, f: (f64, f64)| {
        let good = |p: &&NormPos| match axes {
            FillAxes::PerAxis => inside(get(p), f),
            FillAxes::Joint => inside(p.nx, fx) && inside(p.ny, fy),
        };
        gaze.iter().find(good).map(get).unwrap_or_default()
    };
    let mut last_x = first_good(|p| p.nx, fx);
    let mut last_y = first_good(|p| p.ny, fy);
    let mut out = Vec::with_capacity(segments.len());
    for seg in segments {
        let mut samples = Vec::with_capacity(seg.len());
        for s in seg.samples() {
            counts.samples += 1;
            let pos = if !s.is_gaze() {
                counts.invalid_or_blink += 1;
                counts.total += 1;
                NormPos {
                    nx: last_x,
                    ny: last_y,
                }
            } else {
                let ox = !inside(s.pos.nx, fx);
                let oy = !inside(s.pos.ny, fy);
                counts.outlier_x += usize::from(ox);
                counts.outlier_y += usize::from(oy);
                counts.total += usize::from(ox || oy);
                let (keep_x, keep_y) = match axes {
                    FillAxes::PerAxis => (!ox, !oy),
                    FillAxes::Joint => (!ox && !oy, !ox && !oy),
                };
                if keep_x {
                    last_x = s.pos.nx;
                }
                if keep_y {
                    last_y = s.pos.ny;
                }
                NormPos {
                    nx: last_x,
                    ny: last_y,
                }
            };
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
        let (out, counts) = blink_filter(
            &[seg],
            &BlinkFilterConfig::default(),
            true,
            FillAxes::PerAxis,
        );
        let xs: Vec<f64> = out[0].positions().map(|p| p.nx).collect();
        assert_eq!(counts.invalid_or_blink, 2);
        assert_eq!(counts.outlier_x, 1);
        assert_eq!(counts.total, 3);
        assert_eq!(xs[0], 0.51); // back-filled from the first valid sample
        assert_eq!(xs[3], xs[2]);
        assert_eq!(xs[6], xs[5]);
    }

    /// x steady near 0.50 with spikes at 2 and 4; y steady near 0.30 with
    /// spikes at 0 (before any good y) and 4 (both axes out).
    fn spiky_axes() -> Trajectory<NormPos> {
        let v: Vec<Sample<NormPos>> = (0..20)
            .map(|i| {
                let nx = if i == 2 || i == 4 {
                    9.0
                } else {
                    0.50 + 0.01 * (i % 3) as f64
                };
                let ny = if i == 0 || i == 4 {
                    7.0
                } else {
                    0.30 + 0.01 * (i % 2) as f64
                };
                Sample::new(i as f64, NormPos { nx, ny })
            })
            .collect();
        Trajectory::new(v).unwrap()
    }

    const SPIKY_COUNTS: FillCounts = FillCounts {
        invalid_or_blink: 0,
        outlier_x: 2,
        outlier_y: 2,
        total: 3,
        samples: 20,
    };

    #[test]
    fn blink_filter_counts_and_fills_each_axis_on_its_own() {
        let cfg = BlinkFilterConfig::default();
        let (out, counts) = blink_filter(&[spiky_axes()], &cfg, true, FillAxes::PerAxis);
        let got: Vec<(f64, f64)> = out[0].positions().map(|p| (p.nx, p.ny)).collect();
        // y before the first good y takes the first good y (0.31 at 1).
        assert_eq!(got[0], (0.50, 0.31));
        assert_eq!(got[1], (0.51, 0.31));
        // x held at 1's value, y its own.
        assert_eq!(got[2], (0.51, 0.30));
        assert_eq!(got[3], (0.50, 0.31));
        // Both held at 3's values.
        assert_eq!(got[4], (0.50, 0.31));
        assert_eq!(got[5], (0.52, 0.31));
        assert_eq!(counts, SPIKY_COUNTS);
    }

    #[test]
    fn joint_blink_filter_holds_both_axes_from_the_last_sample_good_on_both() {
        let cfg = BlinkFilterConfig::default();
        let (out, counts) = blink_filter(&[spiky_axes()], &cfg, true, FillAxes::Joint);
        let got: Vec<(f64, f64)> = out[0].positions().map(|p| (p.nx, p.ny)).collect();
        // Sample 1 is the first good on both axes; 0 takes it.
        assert_eq!(got[..3], [(0.51, 0.31); 3]);
        assert_eq!(got[3], (0.50, 0.31));
        assert_eq!(got[4], (0.50, 0.31));
        assert_eq!(counts, SPIKY_COUNTS);
    }
}
