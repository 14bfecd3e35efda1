//! Stage 3: resampling to the target rate on real timestamps, and the
//! paper's speed correction.
//!
//! **When speed correction applies.** Linear interpolation between samples
//! taken at 15-30 fps cuts corners and shortens the path; the paper's
//! `alpha = L_orig / L_resamp` restores it. That is the `auto` rule: sources
//! at most `linear_max_ratio` (2) times the target rate are linearly
//! interpolated and corrected. Faster sources (eye trackers at 250-2000 Hz,
//! synthesized fixation reports) are instead low-pass filtered and decimated
//! ([`eyereplay_signal::gaussian_resample`]): their `L_orig` is dominated by
//! tracker noise and by detail above the target's Nyquist frequency, which a
//! 25 fps signal cannot carry, so "restoring" it would inflate the amplitude
//! by a meaningless factor (on the real 500 Hz EyeLink samples of the test
//! data the ratio exceeds 2).

use crate::config::{ResampleConfig, SpeedCorrection};
use eyereplay_core::{path_length, CanvasPos, Trajectory};
use eyereplay_signal::{
    antialias_sigma_for_gain_s, gaussian_resample, linear_resample, resample_times, Point,
};
use serde::{Deserialize, Serialize};

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ResampleMethod {
    Linear,
    AntiAliasDecimate,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SpeedCorrectionReport {
    pub method: ResampleMethod,
    pub applied: bool,
    /// `L_orig / L_resamp`, reported even when not applied.
    pub alpha: f64,
    pub path_length_orig_px: f64,
    pub path_length_resampled_px: f64,
}

/// Resamples every segment at `k / fps` from its first timestamp, joins the
/// segments, and applies the speed correction when the rule says so. Also
/// returns a blink flag per output frame: set when a source sample within
/// half a frame of it was marked as blink.
pub fn resample_recording(
    segments: &[Trajectory<CanvasPos>],
    rate_hz: f64,
    fps: f64,
    cfg: &ResampleConfig,
) -> (Vec<CanvasPos>, Vec<bool>, SpeedCorrectionReport) {
    let linear = is_linear_rate(rate_hz, fps, cfg.linear_max_ratio);
    let method = if linear {
        ResampleMethod::Linear
    } else {
        ResampleMethod::AntiAliasDecimate
    };
    let sigma = antialias_sigma_for_gain_s(fps, cfg.antialias_stop_gain);
    let mut out: Vec<CanvasPos> = Vec::new();
    let mut blinks: Vec<bool> = Vec::new();
    let (mut l_orig, mut l_res) = (0.0, 0.0);
    for seg in segments {
        let times: Vec<f64> = seg.samples().iter().map(|s| s.t_s).collect();
        let vals: Vec<Point> = seg
            .samples()
            .iter()
            .map(|s| [s.pos.x_px, s.pos.y_px])
            .collect();
        let out_t = resample_times(times[0], *times.last().unwrap_or(&times[0]), fps);
        let res = if linear {
            linear_resample(&times, &vals, &out_t)
        } else {
            gaussian_resample(&times, &vals, &out_t, sigma)
        };
        let res: Vec<CanvasPos> = res
            .into_iter()
            .map(|p| CanvasPos {
                x_px: p[0],
                y_px: p[1],
            })
            .collect();
        blinks.extend(blink_frames(seg, &out_t, 0.5 / fps));
        // Path lengths within segments only: the jump between two segments
        // is not movement.
        l_orig += seg.path_length();
        l_res += path_length(res.iter().copied());
        out.extend(res);
    }
    let alpha = if l_res > 0.0 { l_orig / l_res } else { 1.0 };
    let applied = match cfg.speed_correction {
        SpeedCorrection::Always => true,
        SpeedCorrection::Never => false,
        SpeedCorrection::Auto => linear,
    } && l_res > 0.0;
    if applied {
        scale_about_centroid(&mut out, alpha);
    }
    (
        out,
        blinks,
        SpeedCorrectionReport {
            method,
            applied,
            alpha,
            path_length_orig_px: l_orig,
            path_length_resampled_px: l_res,
        },
    )
}

/// The time in the recording of each frame [`resample_recording`] makes
/// from `segments`: `k / fps` from each segment's first timestamp, segments
/// joined (the same grid, so the two line up frame by frame).
pub fn resampled_times(segments: &[Trajectory<CanvasPos>], fps: f64) -> Vec<f64> {
    segments
        .iter()
        .flat_map(|seg| {
            let s = seg.samples();
            let first = s.first().map_or(0.0, |x| x.t_s);
            let last = s.last().map_or(first, |x| x.t_s);
            resample_times(first, last, fps)
        })
        .collect()
}

/// Relative tolerance of the rate rule. Rates are measured from timestamps
/// (`1 / median interval`), which carry rounding: a 50 fps video whose
/// timestamps start 10 s in measures 50.000000000001 Hz. 1e-6 is far above
/// that and far below any real difference between frame rates.
const RATE_RTOL: f64 = 1e-6;

/// The `auto` rule: linear interpolation (and speed correction) for sources
/// at most `max_ratio` times the target rate, up to measurement rounding.
pub fn is_linear_rate(rate_hz: f64, fps: f64, max_ratio: f64) -> bool {
    rate_hz <= max_ratio * fps * (1.0 + RATE_RTOL)
}

/// For each output time, whether a blink-flagged input sample lies within
/// `half_s` of it.
fn blink_frames(seg: &Trajectory<CanvasPos>, out_t: &[f64], half_s: f64) -> Vec<bool> {
    let s = seg.samples();
    let mut lo = 0usize;
    out_t
        .iter()
        .map(|&t| {
            while lo < s.len() && s[lo].t_s < t - half_s {
                lo += 1;
            }
            s[lo..]
                .iter()
                .take_while(|x| x.t_s < t + half_s)
                .any(|x| x.blink)
        })
        .collect()
}

/// `x' = mean + a (x - mean)` (paper eqs. 3 and 6).
pub fn scale_about_centroid(points: &mut [CanvasPos], a: f64) {
    let Some(m) = eyereplay_core::mean_of(points.iter().copied()) else {
        return;
    };
    for p in points {
        p.x_px = m.x_px + a * (p.x_px - m.x_px);
        p.y_px = m.y_px + a * (p.y_px - m.y_px);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use eyereplay_core::Sample;

    #[test]
    fn resampled_times_line_up_with_the_resampled_frames() {
        // Two segments, 2.5 s at 30 Hz from t = 10 s and 1.0 s from t = 20 s:
        // frames at 10 + k/25 for k = 0..=62, then 20 + k/25 for k = 0..=25
        // (an end that is a whole number of periods is kept).
        let seg = |t0: f64, n: usize| {
            let s: Vec<Sample<CanvasPos>> = (0..n)
                .map(|i| {
                    Sample::new(
                        t0 + i as f64 / 30.0,
                        CanvasPos {
                            x_px: i as f64,
                            y_px: 0.0,
                        },
                    )
                })
                .collect();
            Trajectory::new(s).unwrap()
        };
        let segs = [seg(10.0, 76), seg(20.0, 31)];
        let cfg = ResampleConfig {
            speed_correction: SpeedCorrection::Never,
            ..ResampleConfig::default()
        };
        let (frames, _, _) = resample_recording(&segs, 30.0, 25.0, &cfg);
        let t = resampled_times(&segs, 25.0);
        assert_eq!(t.len(), frames.len());
        assert_eq!(t.len(), 63 + 26);
        assert!((t[62] - 12.48).abs() < 1e-9, "{}", t[62]);
        assert_eq!(t[63], 20.0);
        assert!((t[88] - 21.0).abs() < 1e-9, "{}", t[88]);
        // Linear resampling (no speed correction) of x = 30 (t - 10).
        assert!((frames[25].x_px - 30.0).abs() < 1e-6, "{}", frames[25].x_px);
    }

    #[test]
    fn speed_correction_restores_path_length() {
        // A zig-zag at 24 fps (every sample a corner) resampled to 25 fps
        // loses path length; after correction it is restored exactly, since
        // scaling about the centroid multiplies every step by alpha.
        let samples: Vec<Sample<CanvasPos>> = (0..240)
            .map(|i| {
                Sample::new(
                    i as f64 / 24.0,
                    CanvasPos {
                        x_px: 600.0 + 3.0 * i as f64 * 0.1,
                        y_px: 360.0 + if i % 2 == 0 { 10.0 } else { -10.0 },
                    },
                )
            })
            .collect();
        let seg = Trajectory::new(samples).unwrap();
        let (out, _, rep) = resample_recording(
            std::slice::from_ref(&seg),
            24.0,
            25.0,
            &ResampleConfig::default(),
        );
        assert!(rep.applied);
        assert!(rep.alpha > 1.0, "{rep:?}");
        let l = path_length(out.iter().copied());
        assert!(
            (l - seg.path_length()).abs() < 1e-6 * l,
            "{l} vs {}",
            seg.path_length()
        );
    }

    #[test]
    fn fast_sources_are_decimated_without_correction() {
        let samples: Vec<Sample<CanvasPos>> = (0..5000)
            .map(|i| {
                Sample::new(
                    i as f64 / 500.0,
                    CanvasPos {
                        x_px: 640.0,
                        y_px: 360.0 + (i % 2) as f64,
                    },
                )
            })
            .collect();
        let seg = Trajectory::new(samples).unwrap();
        let (out, _, rep) = resample_recording(&[seg], 500.0, 25.0, &ResampleConfig::default());
        assert_eq!(rep.method, ResampleMethod::AntiAliasDecimate);
        assert!(!rep.applied);
        // 0..9.998 s at 25 fps: 250 frames; the 250 Hz alternation is gone.
        assert_eq!(out.len(), 250);
        // Away from the ends (where the kernel is cut in half) the
        // alternation averages out to its mean.
        assert!(out[5..245].iter().all(|p| (p.y_px - 360.5).abs() < 1e-3));
        assert!(out.iter().all(|p| (p.y_px - 360.5).abs() < 0.05));
    }

    #[test]
    fn blinks_carry_over_to_the_nearest_frames() {
        // 500 Hz with a blink from 1.000 to 1.090 s: the frames at 1.00, 1.04
        // and 1.08 s have blink samples within half a frame (20 ms).
        let samples: Vec<Sample<CanvasPos>> = (0..1000)
            .map(|i| {
                let t = i as f64 / 500.0;
                let mut s = Sample::new(
                    t,
                    CanvasPos {
                        x_px: 1.0,
                        y_px: 2.0,
                    },
                );
                s.blink = (1.0..=1.09).contains(&t);
                s
            })
            .collect();
        let (_, blinks, _) = resample_recording(
            &[Trajectory::new(samples).unwrap()],
            500.0,
            25.0,
            &ResampleConfig::default(),
        );
        let frames: Vec<usize> = (0..blinks.len()).filter(|&k| blinks[k]).collect();
        assert_eq!(frames, vec![25, 26, 27]);
    }

    #[test]
    fn scale_about_centroid_by_hand() {
        let mut p = vec![
            CanvasPos {
                x_px: 0.0,
                y_px: 0.0,
            },
            CanvasPos {
                x_px: 10.0,
                y_px: 20.0,
            },
        ];
        scale_about_centroid(&mut p, 1.05);
        assert!(
            (p[0].x_px - (5.0 - 5.25)).abs() < 1e-12 && (p[1].y_px - (10.0 + 10.5)).abs() < 1e-12
        );
    }

    #[test]
    fn rate_rule_tolerates_measurement_rounding_only() {
        assert!(is_linear_rate(50.0, 25.0, 2.0));
        assert!(is_linear_rate(50.000000000001066, 25.0, 2.0));
        assert!(!is_linear_rate(50.01, 25.0, 2.0));
        assert!(!is_linear_rate(60.0, 25.0, 2.0));
    }
}
