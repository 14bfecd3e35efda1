//! The detector's features: what tells reading from talking in a window
//! of gaze, each a number that does not depend on the recording's unit,
//! calibration or mirroring (the window is normalized and oriented first,
//! [`crate::window`]).
//!
//! Reading moves the eyes in small forward steps along a line and jumps
//! back at its end (a return sweep, a little lower); talking moves them
//! in no preferred direction. So the features measure direction and
//! asymmetry of the horizontal steps at three time scales, saccades and
//! their runs, and how the vertical spread and drift compare with the
//! horizontal. [`FEATURE_NAMES`] lists them in order; `docs/DETECTOR.md`
//! explains each.

pub use crate::moments::skewness;
use crate::window::{lagged_steps, Window, FPS};
use eyereplay_signal::stats::{median, pearson, quantile};

/// Names of [`features`]' values, in order.
pub const FEATURE_NAMES: [&str; 14] = [
    "forward_step_fraction_40ms",
    "forward_step_fraction_200ms",
    "forward_step_fraction_1s",
    "x_step_skewness_40ms",
    "x_step_skewness_200ms",
    "x_step_skewness_1s",
    "saccade_rate_per_s",
    "mean_fixation_s",
    "forward_saccade_fraction",
    "forward_run_fraction",
    "return_sweep_rate_per_s",
    "log_y_to_x_range",
    "y_trend",
    "x_autocorrelation_1s",
];

pub const FEATURE_COUNT: usize = FEATURE_NAMES.len();

/// Lags of the step features, in frames at 25 fps: 40 ms, 200 ms, 1 s.
pub const STEP_LAGS: [usize; 3] = [1, 5, 25];

/// A frame-to-frame move faster than this many times the window's median
/// move is part of a saccade (and at least [`MIN_SACCADE_STEP`]).
pub const SACCADE_SPEED_FACTOR: f64 = 4.0;
/// Smallest frame-to-frame move (in units of the window's 5-95 % x range)
/// that counts as a saccade, so that a window without any noise does not
/// call every tiny move one.
pub const MIN_SACCADE_STEP: f64 = 0.03;
/// A leftward saccade longer than this share of the x range is a return
/// sweep candidate.
pub const RETURN_SWEEP_MIN: f64 = 0.3;
/// Runs of at least this many forward saccades count for
/// `forward_run_fraction` (Bulling et al.'s reading "wordbook" idea).
pub const FORWARD_RUN_MIN: usize = 3;

/// One saccade found in a window: frames `start..=end` moved fast.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Saccade {
    pub start: usize,
    pub end: usize,
    pub dx: f64,
    pub dy: f64,
}

impl Saccade {
    pub fn is_horizontal(&self) -> bool {
        self.dx.abs() >= self.dy.abs()
    }
}

/// The feature vector of a prepared window, in [`FEATURE_NAMES`] order.
pub fn features(w: &Window) -> [f64; FEATURE_COUNT] {
    let n = w.x.len();
    let duration_s = n as f64 / FPS;
    let mut f = [0.0; FEATURE_COUNT];
    for (k, &lag) in STEP_LAGS.iter().enumerate() {
        let steps = lagged_steps(&w.x, lag);
        f[k] = positive_fraction(&steps);
        f[3 + k] = skewness(&steps);
    }
    let sacc = saccades(&w.x, &w.y);
    f[6] = sacc.len() as f64 / duration_s;
    f[7] = mean_fixation_s(&sacc, n);
    let horizontal: Vec<&Saccade> = sacc.iter().filter(|s| s.is_horizontal()).collect();
    f[8] = if horizontal.is_empty() {
        0.5
    } else {
        horizontal.iter().filter(|s| s.dx > 0.0).count() as f64 / horizontal.len() as f64
    };
    f[9] = forward_run_fraction(&sacc);
    f[10] = sacc
        .iter()
        .filter(|s| s.is_horizontal() && s.dx < -RETURN_SWEEP_MIN)
        .count() as f64
        / duration_s;
    let y_range = quantile(&w.y, 0.95).unwrap_or(0.0) - quantile(&w.y, 0.05).unwrap_or(0.0);
    // The x range is 1 after normalization; the floor keeps a flat y finite.
    f[11] = y_range.max(1e-3).ln();
    let t: Vec<f64> = (0..n).map(|i| i as f64).collect();
    f[12] = pearson(&t, &w.y).unwrap_or(0.0);
    f[13] = autocorrelation(&w.x, 25);
    f
}

/// The zero-training rule: the share of a window's saccades that belong to
/// runs of [`FORWARD_RUN_MIN`] or more consecutive forward (rightward, in
/// the oriented window) horizontal saccades. A reader's saccades along a
/// line form such runs; a talker's seldom do. Used as a score as it is.
pub fn forward_run_fraction(sacc: &[Saccade]) -> f64 {
    if sacc.is_empty() {
        return 0.0;
    }
    let mut in_runs = 0;
    let mut run = 0;
    for s in sacc {
        if s.is_horizontal() && s.dx > 0.0 {
            run += 1;
        } else {
            if run >= FORWARD_RUN_MIN {
                in_runs += run;
            }
            run = 0;
        }
    }
    if run >= FORWARD_RUN_MIN {
        in_runs += run;
    }
    in_runs as f64 / sacc.len() as f64
}

/// The rule's score of a prepared window.
pub fn rule_score(w: &Window) -> f64 {
    forward_run_fraction(&saccades(&w.x, &w.y))
}

/// Saccades by a velocity threshold (I-VT) relative to the window's own
/// median frame-to-frame move: at 25 fps a saccade spans one or two frames,
/// and the median move is the fixations' noise.
pub fn saccades(x: &[f64], y: &[f64]) -> Vec<Saccade> {
    let n = x.len().min(y.len());
    if n < 2 {
        return Vec::new();
    }
    let speed: Vec<f64> = (0..n - 1)
        .map(|i| (x[i + 1] - x[i]).hypot(y[i + 1] - y[i]))
        .collect();
    let thr = (SACCADE_SPEED_FACTOR * median(&speed).unwrap_or(0.0)).max(MIN_SACCADE_STEP);
    let mut out = Vec::new();
    let mut i = 0;
    while i < speed.len() {
        if speed[i] > thr {
            let start = i;
            while i + 1 < speed.len() && speed[i + 1] > thr {
                i += 1;
            }
            // Step i moves frame i to i + 1: the saccade ends on frame i + 1.
            out.push(Saccade {
                start,
                end: i + 1,
                dx: x[i + 1] - x[start],
                dy: y[i + 1] - y[start],
            });
        }
        i += 1;
    }
    out
}

/// Mean time between the end of one saccade and the start of the next,
/// with the window's edges as the outer bounds; the whole window when it
/// has no saccade.
fn mean_fixation_s(sacc: &[Saccade], n: usize) -> f64 {
    let mut gaps = Vec::with_capacity(sacc.len() + 1);
    let mut from = 0;
    for s in sacc {
        gaps.push(s.start.saturating_sub(from));
        from = s.end;
    }
    gaps.push(n.saturating_sub(1).saturating_sub(from));
    gaps.iter().sum::<usize>() as f64 / gaps.len() as f64 / FPS
}

/// Share of strictly positive values; 0.5 for none.
pub fn positive_fraction(v: &[f64]) -> f64 {
    if v.is_empty() {
        return 0.5;
    }
    v.iter().filter(|&&d| d > 0.0).count() as f64 / v.len() as f64
}

/// Autocorrelation at `lag` (statsmodels' `acf`: the lagged sum of
/// products over the full variance); 0 when undefined.
pub fn autocorrelation(v: &[f64], lag: usize) -> f64 {
    let n = v.len();
    if lag >= n {
        return 0.0;
    }
    let m = v.iter().sum::<f64>() / n as f64;
    let var: f64 = v.iter().map(|a| (a - m) * (a - m)).sum();
    if var <= 1e-300 {
        return 0.0;
    }
    (0..n - lag)
        .map(|i| (v[i] - m) * (v[i + lag] - m))
        .sum::<f64>()
        / var
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::window::prepare_window;

    #[test]
    fn autocorrelation_matches_statsmodels() {
        // statsmodels acf([1, 2, 3, 4], nlags=1)[1] = 0.25: mean 2.5,
        // lag-1 products (-1.5*-0.5)+(-0.5*0.5)+(0.5*1.5) = 1.25, var sum 5.
        assert!((autocorrelation(&[1.0, 2.0, 3.0, 4.0], 1) - 0.25).abs() < 1e-12);
    }

    fn sacc(dx: f64) -> Saccade {
        Saccade {
            start: 0,
            end: 1,
            dx,
            dy: 0.0,
        }
    }

    #[test]
    fn forward_runs_count_only_runs_of_three_or_more() {
        // + + + - + + - + + + + : runs 3 (counts), 2 (not), 4 (counts) -> 7 of 11.
        let s: Vec<Saccade> = [1, 1, 1, -1, 1, 1, -1, 1, 1, 1, 1]
            .iter()
            .map(|&d| sacc(d as f64))
            .collect();
        assert!((forward_run_fraction(&s) - 7.0 / 11.0).abs() < 1e-12);
        // A vertical saccade breaks a run.
        let mut v = vec![sacc(1.0), sacc(1.0)];
        v.push(Saccade {
            dy: 5.0,
            ..sacc(1.0)
        });
        v.push(sacc(1.0));
        assert_eq!(forward_run_fraction(&v), 0.0);
        assert_eq!(forward_run_fraction(&[]), 0.0);
    }

    #[test]
    fn saccades_are_the_fast_moves_between_steady_stretches() {
        // Steps of 1 unit every 10 frames with 0.001 noise-free hold.
        let x: Vec<f64> = (0..50).map(|i| (i / 10) as f64).collect();
        let y = vec![0.0; 50];
        let s = saccades(&x, &y);
        assert_eq!(s.len(), 4);
        assert_eq!((s[0].start, s[0].end), (9, 10));
        assert!((s[0].dx - 1.0).abs() < 1e-12);
    }

    /// Reading-like and talking-like synthetic windows.
    fn reading_window() -> Window {
        // Lines of 8 forward saccades (0.1 each, 300 ms fixations), a return
        // sweep of 0.8 to the left and a little down.
        let mut xy = Vec::new();
        let (mut x, mut y) = (0.0, 0.0);
        while xy.len() < 250 {
            for _ in 0..8 {
                for _ in 0..7 {
                    xy.push([x, y]);
                }
                x += 0.1;
            }
            for _ in 0..7 {
                xy.push([x, y]);
            }
            x -= 0.8;
            y += 0.05;
        }
        xy.truncate(250);
        prepare_window(&xy, 0).unwrap()
    }

    fn talking_window() -> Window {
        // Fixations at pseudo-random places (a fixed LCG), no direction.
        let mut xy = Vec::new();
        let mut s: u64 = 12345;
        let mut next = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 33) as f64 / (1u64 << 31) as f64
        };
        while xy.len() < 250 {
            let (x, y) = (next(), next());
            for _ in 0..9 {
                xy.push([x, y]);
            }
        }
        xy.truncate(250);
        prepare_window(&xy, 0).unwrap()
    }

    #[test]
    fn reading_and_talking_differ_where_the_features_say_they_should() {
        let r = features(&reading_window());
        let t = features(&talking_window());
        let idx = |name: &str| FEATURE_NAMES.iter().position(|n| *n == name).unwrap();
        assert!(r[idx("forward_run_fraction")] > 0.8, "{r:?}");
        assert!(t[idx("forward_run_fraction")] < 0.3, "{t:?}");
        assert!(r[idx("forward_step_fraction_200ms")] > t[idx("forward_step_fraction_200ms")]);
        assert!(r[idx("x_step_skewness_200ms")] < t[idx("x_step_skewness_200ms")]);
        // 63 frames a line: 3 return sweeps in 250 frames (10 s).
        assert!((r[idx("return_sweep_rate_per_s")] - 0.3).abs() < 1e-9);
        assert!(r[idx("y_trend")] > 0.9);
        // 250 frames, 9 saccades per 63 frames -> about 35 in 10 s.
        assert!((r[idx("saccade_rate_per_s")] - 3.5).abs() < 0.3);
        assert!(r.iter().chain(t.iter()).all(|v| v.is_finite()));
    }
}
