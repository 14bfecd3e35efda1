//! Resampling on real (possibly irregular) timestamps.

use crate::Point;

/// Default gain of the anti-alias filter at the target rate's Nyquist
/// frequency. 0.3 gives a Gaussian of 20 ms at 25 fps: content at 20 Hz
/// (which would fold back to 5 Hz) keeps under 5 % of its amplitude, while
/// the 4-5 Hz rhythm of reading keeps 88 %. A stricter filter (1 % at
/// Nyquist, 39 ms) smeared every saccade over 3 frames and cut the median
/// reading fixation of the OneStop corpus (190 ms, about 5 frames) to 2 frames
/// under the paper's I-VT: far more smoothing than any camera's exposure does
/// (a full 40 ms exposure keeps 64 % at Nyquist).
pub const ANTIALIAS_STOP_GAIN: f64 = 0.3;

/// Output timestamps `t_k = t_start + k / rate_hz` for every `t_k <= t_end`.
///
/// Computed from `k` rather than accumulated, so a long recording does not
/// drift by rounding.
pub fn resample_times(t_start_s: f64, t_end_s: f64, rate_hz: f64) -> Vec<f64> {
    if t_end_s.is_nan() || t_start_s.is_nan() || t_end_s < t_start_s || rate_hz <= 0.0 {
        return Vec::new();
    }
    // A tolerance of 1e-9 s keeps an end time that is an exact multiple of
    // the period from being lost to floating-point error.
    let n = ((t_end_s - t_start_s) * rate_hz + 1e-9).floor() as usize + 1;
    (0..n).map(|k| t_start_s + k as f64 / rate_hz).collect()
}

/// Linear interpolation of `values` (sampled at increasing `times`) at each
/// of `out_times`. Outside the input span the end value is held.
pub fn linear_resample(times: &[f64], values: &[Point], out_times: &[f64]) -> Vec<Point> {
    assert_eq!(times.len(), values.len());
    if times.is_empty() {
        return Vec::new();
    }
    let mut out = Vec::with_capacity(out_times.len());
    let mut j = 0usize;
    for &t in out_times {
        while j + 1 < times.len() && times[j + 1] < t {
            j += 1;
        }
        if t <= times[0] {
            out.push(values[0]);
        } else if j + 1 >= times.len() {
            out.push(values[times.len() - 1]);
        } else {
            let (t0, t1) = (times[j], times[j + 1]);
            let w = (t - t0) / (t1 - t0);
            let (a, b) = (values[j], values[j + 1]);
            out.push([a[0] + w * (b[0] - a[0]), a[1] + w * (b[1] - a[1])]);
        }
    }
    out
}

/// Gaussian width (in seconds) of the anti-alias filter for a target rate:
/// the Gaussian's frequency response `H(f) = exp(-2 pi^2 sigma^2 f^2)` falls
/// to [`ANTIALIAS_STOP_GAIN`] at the target's Nyquist frequency. A Gaussian
/// rather than a sharper windowed sinc because it never rings: a saccade
/// (a step) stays monotonic instead of growing ripples that would read as
/// fake eye movements.
pub fn antialias_sigma_s(target_rate_hz: f64) -> f64 {
    antialias_sigma_for_gain_s(target_rate_hz, ANTIALIAS_STOP_GAIN)
}

/// Like [`antialias_sigma_s`] with the gain at Nyquist given.
pub fn antialias_sigma_for_gain_s(target_rate_hz: f64, stop_gain: f64) -> f64 {
    let nyquist_hz = target_rate_hz / 2.0;
    ((1.0 / stop_gain).ln() / (2.0 * std::f64::consts::PI.powi(2))).sqrt() / nyquist_hz
}

/// Gaussian-weighted average of `values` around each output time (kernel
/// truncated at 4 sigma and renormalized, so irregular sampling and the
/// recording's ends are handled). Low-pass filtering and decimation in one
/// pass, for sources sampled far faster than the target rate.
pub fn gaussian_resample(
    times: &[f64],
    values: &[Point],
    out_times: &[f64],
    sigma_s: f64,
) -> Vec<Point> {
    assert_eq!(times.len(), values.len());
    if times.is_empty() {
        return Vec::new();
    }
    let half = 4.0 * sigma_s;
    let inv_2s2 = 1.0 / (2.0 * sigma_s * sigma_s);
    let mut lo = 0usize;
    let mut out = Vec::with_capacity(out_times.len());
    for &t in out_times {
        while lo < times.len() && times[lo] < t - half {
            lo += 1;
        }
        let (mut sw, mut sx, mut sy) = (0.0, 0.0, 0.0);
        let mut i = lo;
        while i < times.len() && times[i] <= t + half {
            let d = times[i] - t;
            let w = (-d * d * inv_2s2).exp();
            sw += w;
            sx += w * values[i][0];
            sy += w * values[i][1];
            i += 1;
        }
        if sw > 0.0 {
            out.push([sx / sw, sy / sw]);
        } else {
            // No input within 4 sigma (a gap): fall back to interpolation.
            out.extend(linear_resample(times, values, &[t]));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn linear_motion_resamples_exactly_on_irregular_times() {
        // x = 3t + 1, y = -2t, sampled at jittery 24-30 fps timestamps.
        let times: Vec<f64> = (0..200)
            .map(|i| i as f64 / 27.0 + 0.004 * ((i * 7 % 5) as f64 - 2.0))
            .collect();
        let vals: Vec<Point> = times.iter().map(|&t| [3.0 * t + 1.0, -2.0 * t]).collect();
        let out_t = resample_times(times[0], *times.last().unwrap(), 25.0);
        let out = linear_resample(&times, &vals, &out_t);
        for (t, p) in out_t.iter().zip(&out) {
            assert!((p[0] - (3.0 * t + 1.0)).abs() < 1e-12);
            assert!((p[1] + 2.0 * t).abs() < 1e-12);
        }
    }

    #[test]
    fn resample_times_keep_exact_end_and_do_not_drift() {
        let t = resample_times(0.0, 300.0, 25.0);
        assert_eq!(t.len(), 7501);
        assert_eq!(*t.last().unwrap(), 300.0);
    }

    #[test]
    fn antialias_sigma_gives_the_stop_gain_at_nyquist() {
        let s = antialias_sigma_s(25.0);
        let h = |f: f64| (-2.0 * PI * PI * s * s * f * f).exp();
        assert!((h(12.5) - ANTIALIAS_STOP_GAIN).abs() < 1e-12);
        // 20 ms at 25 fps for the default 0.3.
        assert!((s - 0.019_76).abs() < 1e-4, "{s}");
        // 1 Hz (slow pursuit, drifts) passes nearly unchanged.
        assert!(h(1.0) > 0.99);
        let strict = antialias_sigma_for_gain_s(25.0, 0.01);
        assert!((strict - 0.0386).abs() < 1e-4);
    }

    fn amplitude_after_decimation(freq_hz: f64) -> f64 {
        amplitude_after(freq_hz, antialias_sigma_s(25.0))
    }

    fn amplitude_after(freq_hz: f64, s: f64) -> f64 {
        let times: Vec<f64> = (0..5000).map(|i| i as f64 / 500.0).collect();
        let vals: Vec<Point> = times
            .iter()
            .map(|&t| [(2.0 * PI * freq_hz * t).sin(), 0.0])
            .collect();
        let out_t = resample_times(0.5, 9.5, 25.0);
        let out = gaussian_resample(&times, &vals, &out_t, s);
        // Amplitude from the RMS over whole cycles (9 s of output).
        let ms = out.iter().map(|p| p[0] * p[0]).sum::<f64>() / out.len() as f64;
        (2.0 * ms).sqrt()
    }

    #[test]
    fn twenty_hz_at_500hz_does_not_alias_into_25fps() {
        // Naive sampling of a 20 Hz sine at 25 fps aliases to a full-amplitude
        // 5 Hz wave; the filter leaves H(20 Hz) = 0.3^((20/12.5)^2) = 4.6 %.
        let a20 = amplitude_after_decimation(20.0);
        let h20 = ANTIALIAS_STOP_GAIN.powf((20.0f64 / 12.5).powi(2));
        assert!((a20 - h20).abs() < 0.005 && a20 < 0.05, "{a20} vs {h20}");
        // With the strict setting it is gone.
        assert!(amplitude_after(20.0, antialias_sigma_for_gain_s(25.0, 0.01)) < 0.01);
        // A 1 Hz movement keeps the Gaussian's gain H(1 Hz) = 0.971.
        let s = antialias_sigma_s(25.0);
        let h1 = (-2.0 * PI * PI * s * s).exp();
        assert!(
            (amplitude_after_decimation(1.0) - h1).abs() < 0.005,
            "{}",
            amplitude_after_decimation(1.0)
        );
    }
}
