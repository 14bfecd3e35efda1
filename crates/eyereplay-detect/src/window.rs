//! Windows of a gaze track: the unit the detector scores.
//!
//! A [`Track`] is a 25 fps series of `[x, y]` gaze positions in any unit
//! (the extractor's normalized iris position, canvas px): every window is
//! normalized on its own, so the unit and the recording's calibration drop
//! out. Frames without gaze (no face, blinks) are `NaN` and filled linearly
//! inside a window; a window with too many of them is skipped, never scored
//! from a guess.

use eyereplay_signal::stats::{median, quantile};
use serde::{Deserialize, Serialize};

/// The detector's frame rate: the dataset's and the renderer's.
pub const FPS: f64 = 25.0;

/// A window with more frames without gaze than this share is not scored.
pub const MAX_MISSING_FRACTION: f64 = 0.3;

/// Gaps up to this many frames (0.4 s: a blink) are filled by a straight
/// line between the gaze either side; a longer one (a lost face, a look
/// down, dropped frames) holds the last gaze until the gap ends. A line
/// across seconds is a slow, steady drift no eye makes, and it read as
/// reading: a talker's window with 2 s of dropped frames scored 0.78-0.95
/// where the same talk without the gap scored 0.09.
pub const MAX_LINEAR_FILL_FRAMES: usize = 10;

/// A 25 fps gaze series; `NaN` marks a frame without gaze.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Track {
    pub xy: Vec<[f64; 2]>,
}

impl Track {
    pub fn new(xy: Vec<[f64; 2]>) -> Self {
        Track { xy }
    }

    pub fn len(&self) -> usize {
        self.xy.len()
    }

    pub fn is_empty(&self) -> bool {
        self.xy.is_empty()
    }

    pub fn duration_s(&self) -> f64 {
        self.xy.len() as f64 / FPS
    }

    /// The 5 % and 95 % quantiles of x over the frames with gaze; `None`
    /// without any.
    pub fn x_quantiles_5_95(&self) -> Option<(f64, f64)> {
        self.x_quantiles(0.05, 0.95)
    }

    /// Quantiles `lo` and `hi` (in [0, 1]) of x over the frames with gaze;
    /// `None` without any.
    pub fn x_quantiles(&self, lo: f64, hi: f64) -> Option<(f64, f64)> {
        let xs: Vec<f64> = self
            .xy
            .iter()
            .map(|p| p[0])
            .filter(|v| v.is_finite())
            .collect();
        Some((quantile(&xs, lo)?, quantile(&xs, hi)?))
    }
}

/// Window length and step, in frames at [`FPS`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct WindowSpec {
    pub frames: usize,
    /// Distance between window starts; `frames` for non-overlapping windows.
    pub step: usize,
}

impl WindowSpec {
    /// Non-overlapping windows of `seconds` (what scoring uses).
    pub fn seconds(seconds: f64) -> Self {
        let frames = (seconds * FPS).round().max(2.0) as usize;
        WindowSpec {
            frames,
            step: frames,
        }
    }

    /// Windows of `seconds` overlapping by half (what training uses: twice
    /// the windows from the same sessions).
    pub fn half_overlap(seconds: f64) -> Self {
        let w = Self::seconds(seconds);
        WindowSpec {
            step: (w.frames / 2).max(1),
            ..w
        }
    }

    pub fn seconds_long(&self) -> f64 {
        self.frames as f64 / FPS
    }
}

/// A window ready for the features: gaps filled, centred on its median,
/// scaled so that the 5-95 % range of x is 1 (the same factor on y, so
/// their ratio survives), and mirrored where needed so that its large
/// horizontal steps point left (see [`Window::mirrored`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Window {
    /// First frame in the track.
    pub start: usize,
    pub x: Vec<f64>,
    pub y: Vec<f64>,
    /// Share of frames that had no gaze and were filled.
    pub missing_fraction: f64,
    /// Whether x was flipped. A webcam video may be mirrored or not, and a
    /// reader's eyes then move right-then-jump-left or the reverse; the
    /// detector must not depend on which. Each window is oriented so that
    /// the skew of its 200 ms x-steps is negative (the few large steps go
    /// left, as a reader's return sweeps do), which makes every feature the
    /// same for a video and its mirror image.
    pub mirrored: bool,
}

/// Frames in 200 ms: the lag that orients a window.
pub const LAG_200MS: usize = 5;

/// Cuts `track` into windows of `spec`, skipping windows with more than
/// [`MAX_MISSING_FRACTION`] of frames without gaze. A track shorter than one
/// window gives none.
pub fn windows(track: &Track, spec: WindowSpec) -> Vec<Window> {
    let mut out = Vec::new();
    if spec.frames < 2 || track.len() < spec.frames {
        return out;
    }
    let mut start = 0;
    while start + spec.frames <= track.len() {
        if let Some(w) = prepare_window(&track.xy[start..start + spec.frames], start) {
            out.push(w);
        }
        start += spec.step.max(1);
    }
    out
}

/// Fills, normalizes and orients one window; `None` when too much is missing.
pub fn prepare_window(xy: &[[f64; 2]], start: usize) -> Option<Window> {
    let n = xy.len();
    let valid: Vec<usize> = (0..n)
        .filter(|&i| xy[i][0].is_finite() && xy[i][1].is_finite())
        .collect();
    let missing_fraction = 1.0 - valid.len() as f64 / n as f64;
    if valid.len() < 2 || missing_fraction > MAX_MISSING_FRACTION {
        return None;
    }
    let mut x = fill(xy, &valid, 0);
    let mut y = fill(xy, &valid, 1);
    let (mx, my) = (median(&x)?, median(&y)?);
    let range = quantile(&x, 0.95)? - quantile(&x, 0.05)?;
    // A window whose x does not move at all has no shape to read; a tiny
    // floor keeps the arithmetic finite and the features near neutral.
    let scale = if range > 1e-12 { range } else { 1e-12 };
    for v in x.iter_mut() {
        *v = (*v - mx) / scale;
    }
    for v in y.iter_mut() {
        *v = (*v - my) / scale;
    }
    let steps = lagged_steps(&x, LAG_200MS);
    let mirrored = crate::moments::skewness(&steps) > 0.0;
    if mirrored {
        for v in x.iter_mut() {
            *v = -*v;
        }
    }
    Some(Window {
        start,
        x,
        y,
        missing_fraction,
        mirrored,
    })
}

/// `v[i + lag] - v[i]` for every `i`.
pub fn lagged_steps(v: &[f64], lag: usize) -> Vec<f64> {
    if lag == 0 || v.len() <= lag {
        return Vec::new();
    }
    (0..v.len() - lag).map(|i| v[i + lag] - v[i]).collect()
}

/// Axis `k` of `xy` with frames outside `valid` filled linearly between the
/// nearest valid frames where the gap is short ([`MAX_LINEAR_FILL_FRAMES`]),
/// else held at the frame before it (and held flat before the first and
/// after the last).
fn fill(xy: &[[f64; 2]], valid: &[usize], k: usize) -> Vec<f64> {
    let mut out = vec![0.0; xy.len()];
    let first = valid[0];
    let last = *valid.last().unwrap_or(&first);
    for v in out.iter_mut().take(first) {
        *v = xy[first][k];
    }
    for pair in valid.windows(2) {
        let (a, b) = (pair[0], pair[1]);
        let (va, vb) = (xy[a][k], xy[b][k]);
        // b - a - 1 frames are missing between a and b.
        let line = b - a - 1 <= MAX_LINEAR_FILL_FRAMES;
        for (i, v) in out.iter_mut().enumerate().take(b).skip(a) {
            *v = if line {
                va + (vb - va) * (i - a) as f64 / (b - a) as f64
            } else {
                va
            };
        }
    }
    for v in out.iter_mut().skip(last) {
        *v = xy[last][k];
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp(n: usize) -> Track {
        Track::new((0..n).map(|i| [i as f64, 0.5 * i as f64]).collect())
    }

    #[test]
    fn windows_tile_the_track_and_overlap_by_half_when_asked() {
        let t = ramp(1000);
        let w = windows(&t, WindowSpec::seconds(10.0));
        assert_eq!(w.len(), 4); // 1000 frames = 4 x 250
        assert_eq!(w[3].start, 750);
        let o = windows(&t, WindowSpec::half_overlap(10.0));
        assert_eq!(o.len(), 7); // starts 0, 125, ..., 750
        assert!(windows(&ramp(249), WindowSpec::seconds(10.0)).is_empty());
    }

    #[test]
    fn normalization_centres_on_the_median_and_scales_x_to_its_5_95_range() {
        // x = 0..99 (a ramp): median 49.5, 5-95 % range 89.1 (numpy's
        // linear quantiles: 4.95 and 94.05); y is half of x.
        let w = prepare_window(&ramp(100).xy, 0).unwrap();
        assert!((w.x[0] - (-49.5 / 89.1)).abs() < 1e-12);
        assert!((w.y[99] - (0.5 * 99.0 - 24.75) / 89.1).abs() < 1e-12);
    }

    #[test]
    fn gaps_are_filled_linearly_and_too_many_gaps_skip_the_window() {
        let mut xy = ramp(10).xy;
        xy[3] = [f64::NAN, f64::NAN];
        xy[4] = [f64::NAN, f64::NAN];
        let w = prepare_window(&xy, 0).unwrap();
        let full = prepare_window(&ramp(10).xy, 0).unwrap();
        for i in 0..10 {
            assert!((w.x[i] - full.x[i]).abs() < 1e-12, "frame {i}");
        }
        assert!((w.missing_fraction - 0.2).abs() < 1e-12);
        xy[5] = [f64::NAN, 0.0];
        xy[6] = [0.0, f64::NAN];
        assert!(prepare_window(&xy, 0).is_none()); // 40 % missing
    }

    #[test]
    fn a_long_gap_holds_the_gaze_before_it_rather_than_drawing_a_line() {
        // x = 0..249 with frames 100..150 missing (2 s): held at x 99 until
        // frame 150 (x 150), where a line would climb through the gap.
        let mut xy = ramp(250).xy;
        for p in &mut xy[100..150] {
            *p = [f64::NAN, f64::NAN];
        }
        let w = prepare_window(&xy, 0).unwrap();
        let step = w.x[1] - w.x[0];
        for i in 100..150 {
            assert!((w.x[i] - w.x[99]).abs() < 1e-12, "frame {i} held");
        }
        assert!((w.x[150] - w.x[99] - 51.0 * step).abs() < 1e-9);
        // A gap of MAX_LINEAR_FILL_FRAMES frames is still a line.
        let mut xy = ramp(250).xy;
        for p in &mut xy[100..100 + MAX_LINEAR_FILL_FRAMES] {
            *p = [f64::NAN, f64::NAN];
        }
        let w = prepare_window(&xy, 0).unwrap();
        let full = prepare_window(&ramp(250).xy, 0).unwrap();
        for i in 0..250 {
            assert!((w.x[i] - full.x[i]).abs() < 1e-12, "frame {i}");
        }
    }

    #[test]
    fn a_window_and_its_mirror_image_come_out_the_same() {
        // A sawtooth: slow rightward drift, fast leftward return.
        let xy: Vec<[f64; 2]> = (0..250)
            .map(|i| [(i % 50) as f64, (i / 50) as f64])
            .collect();
        let mirror: Vec<[f64; 2]> = xy.iter().map(|p| [-p[0], p[1]]).collect();
        let a = prepare_window(&xy, 0).unwrap();
        let b = prepare_window(&mirror, 0).unwrap();
        assert!(!a.mirrored && b.mirrored);
        for i in 0..250 {
            assert!((a.x[i] - b.x[i]).abs() < 1e-12);
        }
    }
}

/// `track` with white noise on both axes: per frame, independent, with a
/// standard deviation of `k` times the track's 5-95 % x range (the
/// webcam-like degradation of docs/DETECTOR.md), from `seed`.
pub fn with_white_noise(track: &Track, k: f64, seed: u64) -> Track {
    use rand::SeedableRng;
    use rand_distr::Distribution;
    if k <= 0.0 {
        return track.clone();
    }
    let range = track.x_quantiles_5_95().map_or(0.0, |(lo, hi)| hi - lo);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let normal = rand_distr::Normal::new(0.0, (k * range).max(1e-12)).expect("finite sigma");
    Track::new(
        track
            .xy
            .iter()
            .map(|p| {
                [
                    p[0] + normal.sample(&mut rng),
                    p[1] + normal.sample(&mut rng),
                ]
            })
            .collect(),
    )
}

/// A stable 64-bit hash of a name (FNV-1a), to seed per-recording noise.
pub fn name_seed(seed: u64, name: &str) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64 ^ seed;
    for b in name.bytes() {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

#[cfg(test)]
mod noise_tests {
    use super::*;

    #[test]
    fn noise_has_the_asked_spread_and_is_reproducible() {
        // x = 0..999: 5-95 % range 899.1 (numpy linear); k = 0.1 -> sd 89.91.
        let t = Track::new((0..1000).map(|i| [i as f64, 0.0]).collect());
        let a = with_white_noise(&t, 0.1, 7);
        let d: Vec<f64> = a.xy.iter().zip(&t.xy).map(|(a, b)| a[1] - b[1]).collect();
        let sd = (d.iter().map(|v| v * v).sum::<f64>() / d.len() as f64).sqrt();
        assert!((sd / 89.91 - 1.0).abs() < 0.1, "{sd}");
        assert_eq!(a, with_white_noise(&t, 0.1, 7));
        assert_ne!(a, with_white_noise(&t, 0.1, 8));
        assert_eq!(with_white_noise(&t, 0.0, 7), t);
    }
}
