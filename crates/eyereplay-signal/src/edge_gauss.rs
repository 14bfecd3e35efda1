//! EdgeGauss: heavy Gaussian smoothing that keeps saccades sharp.
//!
//! The paper names the method but gives no formula; this is our design.
//!
//! 1. **Noise scale.** Per-sample jitter `sigma_n` is estimated robustly from
//!    the median step length: for isotropic Gaussian noise of per-axis
//!    deviation `sigma`, the step length is Rayleigh-distributed with median
//!    `2 sqrt(ln 2) sigma`; real movement occupies few samples, so the median
//!    sees noise.
//! 2. **Edges.** At each boundary between samples `b-1` and `b`, the step
//!    statistic `S_b = || mean(x[b .. b+k]) - mean(x[b-k .. b]) ||` compares
//!    the means of `k` samples on either side. Under noise alone it is
//!    Rayleigh with scale `sigma_n sqrt(2/k)`; a boundary is an edge (a
//!    saccade) where `S_b > max(z sigma_n sqrt(2/k), min_step)` and `S_b` is
//!    the largest statistic within `k - 1` boundaries on either side.
//! 3. **Smoothing.** Between edges the signal is smoothed with a Gaussian of
//!    width `sigma_s` seconds, truncated at the segment's ends and
//!    renormalized, so no averaging crosses a saccade: the step is restored at
//!    its full height, while the fixation jitter is removed.
//!
//! Defaults: `sigma_s = 0.12` s (3 frames at 25 fps: heavy enough to bring
//! webcam landmark jitter below the paper's 5 px/frame fixation threshold),
//! `window_s = 0.12` s, `z = 4` (false-edge rate under pure noise about
//! `exp(-z^2/2)` = 3e-4 per boundary before the local-maximum test).

use crate::{dist, Point};
use serde::{Deserialize, Serialize};

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EdgeGaussParams {
    /// Width of the within-segment Gaussian, seconds.
    pub sigma_s: f64,
    /// Length of each of the two windows of the step detector, seconds.
    pub window_s: f64,
    /// Edge threshold in units of the step statistic's noise scale.
    pub z: f64,
    /// Smallest step (in the signal's unit) ever treated as an edge.
    pub min_step: f64,
}

impl Default for EdgeGaussParams {
    fn default() -> Self {
        EdgeGaussParams {
            sigma_s: 0.12,
            window_s: 0.12,
            z: 4.0,
            min_step: 0.0,
        }
    }
}

/// What EdgeGauss found, for the run's report.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize, Default)]
pub struct EdgeGaussReport {
    /// Saccade edges kept sharp.
    pub edges: usize,
    /// Estimated per-axis noise deviation, in the signal's unit.
    pub noise_sigma: f64,
    /// Step threshold used, in the signal's unit.
    pub threshold: f64,
}

/// Applies EdgeGauss to `values` sampled at increasing `times` (seconds).
pub fn edge_gauss(
    times: &[f64],
    values: &[Point],
    params: &EdgeGaussParams,
) -> (Vec<Point>, EdgeGaussReport) {
    let n = values.len();
    assert_eq!(times.len(), n);
    if n < 3 {
        return (values.to_vec(), EdgeGaussReport::default());
    }
    let dt = median_dt(times);
    let k = ((params.window_s / dt).round() as usize).max(1);

    let mut steps: Vec<f64> = values.windows(2).map(|w| dist(w[0], w[1])).collect();
    let mid = steps.len() / 2;
    let med = *steps.select_nth_unstable_by(mid, |a, b| a.total_cmp(b)).1;
    let noise_sigma = med / (2.0 * std::f64::consts::LN_2.sqrt());
    let threshold = (params.z * noise_sigma * (2.0 / k as f64).sqrt()).max(params.min_step);

    // Prefix sums give each window mean in O(1).
    let mut px = vec![0.0; n + 1];
    let mut py = vec![0.0; n + 1];
    for i in 0..n {
        px[i + 1] = px[i] + values[i][0];
        py[i + 1] = py[i] + values[i][1];
    }
    let mean = |a: usize, b: usize| -> Point {
        let m = (b - a) as f64;
        [(px[b] - px[a]) / m, (py[b] - py[a]) / m]
    };
    // stat[b] for boundary b in 1..n (between samples b-1 and b).
    let mut stat = vec![0.0; n];
    for (b, s) in stat.iter_mut().enumerate().skip(1) {
        let left = mean(b.saturating_sub(k), b);
        let right = mean(b, (b + k).min(n));
        *s = dist(left, right);
    }
    let mut cuts = vec![0usize];
    for b in 1..n {
        if stat[b] <= threshold {
            continue;
        }
        let lo = b.saturating_sub(k - 1).max(1);
        let hi = (b + k).min(n);
        // Ties go to the earliest boundary so a flat plateau yields one edge.
        let is_peak =
            (lo..hi).all(|o| o == b || stat[o] < stat[b] || (stat[o] == stat[b] && o > b));
        if is_peak {
            cuts.push(b);
        }
    }
    let edges = cuts.len() - 1;
    cuts.push(n);

    let mut out = Vec::with_capacity(n);
    for seg in cuts.windows(2) {
        smooth_segment(
            &times[seg[0]..seg[1]],
            &values[seg[0]..seg[1]],
            params.sigma_s,
            &mut out,
        );
    }
    (
        out,
        EdgeGaussReport {
            edges,
            noise_sigma,
            threshold,
        },
    )
}

fn median_dt(times: &[f64]) -> f64 {
    let dt: Vec<f64> = times.windows(2).map(|w| w[1] - w[0]).collect();
    crate::stats::upper_median(&dt).expect("callers pass at least two times")
}

fn smooth_segment(times: &[f64], values: &[Point], sigma_s: f64, out: &mut Vec<Point>) {
    if sigma_s <= 0.0 {
        out.extend_from_slice(values);
        return;
    }
    let half = 4.0 * sigma_s;
    let inv = 1.0 / (2.0 * sigma_s * sigma_s);
    let mut lo = 0usize;
    for &t in times {
        while times[lo] < t - half {
            lo += 1;
        }
        let (mut sw, mut sx, mut sy) = (0.0, 0.0, 0.0);
        for j in lo..times.len() {
            let d = times[j] - t;
            if d > half {
                break;
            }
            let w = (-d * d * inv).exp();
            sw += w;
            sx += w * values[j][0];
            sy += w * values[j][1];
        }
        out.push([sx / sw, sy / sw]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Deterministic pseudo-normal noise (sum of 12 uniforms - 6) from an LCG,
    /// so the test does not depend on a random crate.
    fn noise(seed: &mut u64) -> f64 {
        let mut s = 0.0;
        for _ in 0..12 {
            *seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            s += (*seed >> 11) as f64 / (1u64 << 53) as f64;
        }
        s - 6.0
    }

    #[test]
    fn keeps_saccade_steps_and_removes_jitter() {
        // 25 fps, fixations of 1 s at x = 0, 100, 40, 40 (no step), jitter sigma 5.
        let mut seed = 7u64;
        let levels = [0.0, 100.0, 40.0, 40.0];
        let mut times = Vec::new();
        let mut vals = Vec::new();
        for (f, lvl) in levels.iter().enumerate() {
            for i in 0..25 {
                times.push((f * 25 + i) as f64 / 25.0);
                vals.push([lvl + 5.0 * noise(&mut seed), 50.0 + 5.0 * noise(&mut seed)]);
            }
        }
        let (out, rep) = edge_gauss(&times, &vals, &EdgeGaussParams::default());
        assert_eq!(rep.edges, 2, "{rep:?}");
        // Noise estimate within 25 % of the true 5.
        assert!((rep.noise_sigma - 5.0).abs() < 1.25, "{rep:?}");
        // The steps stay one frame wide and at least 90 % of their height.
        assert!(out[25][0] - out[24][0] > 90.0);
        assert!(out[49][0] - out[50][0] > 54.0);
        // Inside fixations the jitter drops well below the raw 5.
        let speeds: Vec<f64> = out[2..22].windows(2).map(|w| dist(w[0], w[1])).collect();
        let raw: Vec<f64> = vals[2..22].windows(2).map(|w| dist(w[0], w[1])).collect();
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        assert!(
            mean(&speeds) < 0.25 * mean(&raw),
            "{} vs {}",
            mean(&speeds),
            mean(&raw)
        );
    }

    #[test]
    fn constant_signal_is_unchanged() {
        let times: Vec<f64> = (0..50).map(|i| i as f64 * 0.04).collect();
        let vals = vec![[3.0, 4.0]; 50];
        let (out, rep) = edge_gauss(&times, &vals, &EdgeGaussParams::default());
        assert_eq!(rep.edges, 0);
        assert!(out
            .iter()
            .all(|p| (p[0] - 3.0).abs() < 1e-12 && (p[1] - 4.0).abs() < 1e-12));
    }
}
