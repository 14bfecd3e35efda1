//! Visual mapping fidelity (paper section 5.2): a source iris trajectory,
//! normalized within the eye aperture, against the iris trajectory extracted
//! back from the rendered video of that same trajectory, frame by frame.

use crate::stats::{mean, pearson, quantile_sorted, sorted, std_pop};
use crate::EvalError;
use eyereplay_core::{Canvas, CanvasPos};
use serde::Serialize;

/// Targets at reading scale (issue 5): r >= 0.95 on both axes, amplitude
/// ratio within 0.9-1.1.
pub const TARGET_R_MIN: f64 = 0.95;
pub const TARGET_AMPLITUDE_RATIO: (f64, f64) = (0.9, 1.1);

/// Per-axis agreement.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct AxisFidelity {
    /// Pearson r between source and rendered; `None` when either is constant.
    pub r: Option<f64>,
    /// `std(rendered) / std(source)` (population std); `None` when the
    /// source is constant. Noise in the read-back inflates it by about
    /// `1 / r`, so at small excursions (low r) it overstates the gain.
    pub amplitude_ratio: Option<f64>,
    /// Least-squares slope of rendered on source (`r * std ratio`): how much
    /// of a source movement comes back, unbiased by read-back noise.
    pub gain: Option<f64>,
    pub std_source: f64,
    pub std_rendered: f64,
}

impl AxisFidelity {
    pub fn meets_targets(&self) -> bool {
        let (lo, hi) = TARGET_AMPLITUDE_RATIO;
        matches!(self.r, Some(r) if r >= TARGET_R_MIN)
            && matches!(self.amplitude_ratio, Some(a) if (lo..=hi).contains(&a))
    }
}

/// Per-frame Euclidean error in normalized iris units.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ErrorStats {
    pub mean: f64,
    pub median: f64,
    pub p95: f64,
}

/// Extent of the cursor input that drove the render.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct InputRange {
    /// `max - min` per axis, canvas px.
    pub range_px: [f64; 2],
    /// The same as a percentage of the canvas width / height.
    pub range_pct_canvas: [f64; 2],
    /// 5th-95th percentile spread per axis, canvas px (robust to outliers).
    pub p5_p95_px: [f64; 2],
}

/// Result of [`compare_visual`].
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct VisualFidelity {
    pub n_frames: usize,
    pub x: AxisFidelity,
    pub y: AxisFidelity,
    pub error: ErrorStats,
    pub input: Option<InputRange>,
    /// Per-frame errors, kept for the histogram.
    #[serde(skip)]
    pub errors: Vec<f64>,
}

impl VisualFidelity {
    pub fn meets_targets(&self) -> bool {
        self.x.meets_targets() && self.y.meets_targets()
    }

    /// `r x .. y .., amplitude ratio x .. y .., error mean .. median .. p95 ..`,
    /// as the command line and the report print it.
    pub fn summary(&self) -> String {
        let f = |o: Option<f64>| o.map_or("n/a".to_string(), |x| format!("{x:.3}"));
        format!(
            "r x {} y {}, amplitude ratio x {} y {}, error mean {:.4} median {:.4} p95 {:.4}",
            f(self.x.r),
            f(self.y.r),
            f(self.x.amplitude_ratio),
            f(self.y.amplitude_ratio),
            self.error.mean,
            self.error.median,
            self.error.p95
        )
    }
}

fn axis(src: &[f64], ren: &[f64]) -> AxisFidelity {
    let (ss, sr) = (std_pop(src).unwrap_or(0.0), std_pop(ren).unwrap_or(0.0));
    let r = pearson(src, ren);
    let amplitude_ratio = (ss > 0.0).then(|| sr / ss);
    AxisFidelity {
        r,
        amplitude_ratio,
        gain: r.zip(amplitude_ratio).map(|(r, a)| r * a),
        std_source: ss,
        std_rendered: sr,
    }
}

/// Cursor input extent on the canvas.
pub fn input_range(input: &[CanvasPos], canvas: Canvas) -> Option<InputRange> {
    if input.is_empty() {
        return None;
    }
    let xs = sorted(&input.iter().map(|p| p.x_px).collect::<Vec<_>>());
    let ys = sorted(&input.iter().map(|p| p.y_px).collect::<Vec<_>>());
    let span = |s: &[f64]| s[s.len() - 1] - s[0];
    let robust = |s: &[f64]| quantile_sorted(s, 0.95).unwrap() - quantile_sorted(s, 0.05).unwrap();
    let range_px = [span(&xs), span(&ys)];
    Some(InputRange {
        range_px,
        range_pct_canvas: [
            100.0 * range_px[0] / canvas.width_px as f64,
            100.0 * range_px[1] / canvas.height_px as f64,
        ],
        p5_p95_px: [robust(&xs), robust(&ys)],
    })
}

/// Compares two frame-aligned normalized iris signals `(nx, ny)`.
///
/// `input` is the cursor trajectory that drove the render (for the input
/// range); pass `None` when unknown. Frames where either signal is not
/// finite (the extractor found no eye) are left out; at least two frames
/// must remain. Lengths must match: a video whose frame count differs from
/// its trajectory is an error, not something to trim silently.
pub fn compare_visual(
    source_n: &[[f64; 2]],
    rendered_n: &[[f64; 2]],
    input: Option<(&[CanvasPos], Canvas)>,
) -> Result<VisualFidelity, EvalError> {
    if source_n.len() != rendered_n.len() {
        return Err(EvalError::Stats(format!(
            "visual comparison: source has {} frames, rendered has {}",
            source_n.len(),
            rendered_n.len()
        )));
    }
    let pairs: Vec<([f64; 2], [f64; 2])> = source_n
        .iter()
        .zip(rendered_n)
        .filter(|(s, r)| s.iter().chain(r.iter()).all(|v| v.is_finite()))
        .map(|(s, r)| (*s, *r))
        .collect();
    if pairs.len() < 2 {
        return Err(EvalError::Stats(format!(
            "visual comparison: only {} frame(s) with both signals finite",
            pairs.len()
        )));
    }
    let col = |f: fn(&([f64; 2], [f64; 2])) -> f64| pairs.iter().map(f).collect::<Vec<_>>();
    let (sx, sy, rx, ry) = (
        col(|p| p.0[0]),
        col(|p| p.0[1]),
        col(|p| p.1[0]),
        col(|p| p.1[1]),
    );
    let errors: Vec<f64> = pairs
        .iter()
        .map(|(s, r)| (r[0] - s[0]).hypot(r[1] - s[1]))
        .collect();
    let es = sorted(&errors);
    Ok(VisualFidelity {
        n_frames: pairs.len(),
        x: axis(&sx, &rx),
        y: axis(&sy, &ry),
        error: ErrorStats {
            mean: mean(&errors).unwrap(),
            median: quantile_sorted(&es, 0.5).unwrap(),
            p95: quantile_sorted(&es, 0.95).unwrap(),
        },
        input: input.and_then(|(pts, c)| input_range(pts, c)),
        errors,
    })
}

/// One eye in one compared frame, for [`read_back_budget`]: what the
/// extractor read from the video and where the renderer drew the iris.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EyeReadBack {
    /// Iris centre as read, image px.
    pub iris_px: [f64; 2],
    /// The eye's corners on the image's left and right, as read.
    pub corner_left_px: [f64; 2],
    pub corner_right_px: [f64; 2],
    /// Lid gap over corner-to-corner width, as read.
    pub aperture: f64,
    /// This eye's `(nx, ny)` as read.
    pub n: [f64; 2],
    /// Iris centre as drawn (the render's ground truth), image px.
    pub drawn_iris_px: [f64; 2],
}

/// One axis of a [`ReadBackBudget`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct AxisBudget {
    /// How far the eye moves: the std of the source's n on this axis times
    /// the length n is measured in (x: the corner-to-corner width; y: the
    /// lid-to-lid height), image px, mean of both eyes.
    pub movement_px: f64,
    /// The extractor's own error on the iris centre: the std of the drawn
    /// minus the read centre (x: along the corner-to-corner axis; y: the
    /// image's y), image px, mean of both eyes.
    pub iris_error_px: f64,
    /// Pearson r against the source with the drawn iris centre put in place
    /// of the read one (corners and lids as read), mean n of both eyes:
    /// what r would be if the iris network found the centre exactly.
    pub r_drawn_iris: Option<f64>,
}

/// Why a read-back r can be low: per axis, the movement to be read against
/// the extractor's error on the iris centre, both in image pixels. Where
/// the error is a sizeable fraction of the movement, r falls whatever the
/// renderer draws (r is about `m / sqrt(m^2 + e^2)` for movement `m` and an
/// error `e` independent of it; an error that follows the movement, as a
/// gain does, costs r less).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ReadBackBudget {
    /// Frames compared.
    pub frames: usize,
    pub x: AxisBudget,
    pub y: AxisBudget,
}

/// The [`ReadBackBudget`] of the compared frames: `source[i]` the source's
/// `(nx, ny)` and `eyes[i]` both eyes (image-left first) of frame `i`.
/// `None` with fewer than 3 frames or lengths that differ.
pub fn read_back_budget(source: &[[f64; 2]], eyes: &[[EyeReadBack; 2]]) -> Option<ReadBackBudget> {
    if source.len() != eyes.len() || source.len() < 3 {
        return None;
    }
    let axis = |k: usize| -> Option<AxisBudget> {
        let target: Vec<f64> = source.iter().map(|s| s[k]).collect();
        let (mut lengths, mut errors) = (0.0, 0.0);
        let mut n_drawn = vec![0.0; eyes.len()];
        for side in 0..2 {
            let (mut len_px, mut dev) = (Vec::new(), Vec::new());
            for e in eyes.iter().map(|f| &f[side]) {
                let (ux, uy) = (
                    e.corner_right_px[0] - e.corner_left_px[0],
                    e.corner_right_px[1] - e.corner_left_px[1],
                );
                let w = ux.hypot(uy);
                let (dx, dy) = (
                    e.drawn_iris_px[0] - e.iris_px[0],
                    e.drawn_iris_px[1] - e.iris_px[1],
                );
                let (length, d) = if k == 0 {
                    (w, (dx * ux + dy * uy) / w)
                } else {
                    (e.aperture * w, dy)
                };
                len_px.push(length);
                dev.push(d);
            }
            // n moves by d / length when the iris centre moves by d px.
            for (i, f) in eyes.iter().enumerate() {
                n_drawn[i] += 0.5 * (f[side].n[k] + dev[i] / len_px[i]);
            }
            lengths += mean(&len_px)?;
            errors += std_pop(&dev)?;
        }
        Some(AxisBudget {
            movement_px: std_pop(&target)? * lengths / 2.0,
            iris_error_px: errors / 2.0,
            r_drawn_iris: pearson(&target, &n_drawn),
        })
    };
    Some(ReadBackBudget {
        frames: source.len(),
        x: axis(0)?,
        y: axis(1)?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identical_signals_are_perfect() {
        let s: Vec<[f64; 2]> = (0..50)
            .map(|i| {
                [
                    0.5 + 0.1 * (i as f64 * 0.3).sin(),
                    0.5 + 0.05 * (i as f64 * 0.2).cos(),
                ]
            })
            .collect();
        let v = compare_visual(&s, &s, None).unwrap();
        assert_eq!(v.error.mean, 0.0);
        assert!((v.x.r.unwrap() - 1.0).abs() < 1e-12);
        assert!((v.y.amplitude_ratio.unwrap() - 1.0).abs() < 1e-12);
        assert!(v.meets_targets());
    }

    #[test]
    fn hand_worked_attenuated_copy() {
        // Source x: 0.4, 0.6, 0.4, 0.6 (std 0.1); rendered x at 30 % amplitude
        // about 0.5: 0.47, 0.53, ... (std 0.03); y constant 0.5 in both.
        let s = [[0.4, 0.5], [0.6, 0.5], [0.4, 0.5], [0.6, 0.5]];
        let r = [[0.47, 0.5], [0.53, 0.5], [0.47, 0.5], [0.53, 0.5]];
        let input = [
            CanvasPos {
                x_px: 600.0,
                y_px: 300.0,
            },
            CanvasPos {
                x_px: 700.0,
                y_px: 455.0,
            },
        ];
        let v = compare_visual(&s, &r, Some((&input, Canvas::default()))).unwrap();
        assert!((v.x.amplitude_ratio.unwrap() - 0.3).abs() < 1e-12);
        assert!((v.x.r.unwrap() - 1.0).abs() < 1e-12);
        assert!((v.x.gain.unwrap() - 0.3).abs() < 1e-12);
        assert_eq!(v.y.r, None);
        assert_eq!(v.y.gain, None);
        // every frame is 0.07 off
        assert!((v.error.mean - 0.07).abs() < 1e-12);
        assert!((v.error.p95 - 0.07).abs() < 1e-12);
        let inp = v.input.unwrap();
        assert_eq!(inp.range_px, [100.0, 155.0]);
        assert!((inp.range_pct_canvas[0] - 7.8125).abs() < 1e-12);
        assert!(!v.meets_targets());
    }

    #[test]
    fn noise_inflates_the_ratio_but_not_the_gain() {
        // Source x: -1, 1, -1, 1 around 0.5 (scaled by 0.1); rendered adds
        // noise +-0.1 uncorrelated with it: 1, 1, -1, -1 (scaled by 0.1).
        // Worked by hand: std source 0.1, std rendered 0.1 * sqrt(2), r =
        // 1 / sqrt(2), so the ratio is sqrt(2) and the gain r * ratio = 1.
        let s: Vec<[f64; 2]> = [-1.0, 1.0, -1.0, 1.0]
            .iter()
            .map(|&a| [0.5 + 0.1 * a, 0.5])
            .collect();
        let noise = [1.0, 1.0, -1.0, -1.0];
        let r: Vec<[f64; 2]> = s
            .iter()
            .zip(noise)
            .map(|(p, e)| [p[0] + 0.1 * e, 0.5])
            .collect();
        let v = compare_visual(&s, &r, None).unwrap();
        assert!((v.x.amplitude_ratio.unwrap() - 2f64.sqrt()).abs() < 1e-12);
        assert!((v.x.r.unwrap() - 1.0 / 2f64.sqrt()).abs() < 1e-12);
        assert!((v.x.gain.unwrap() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn length_mismatch_is_an_error() {
        let e = compare_visual(&[[0.0, 0.0]; 3], &[[0.0, 0.0]; 2], None).unwrap_err();
        assert!(e.to_string().contains("3 frames"), "{e}");
    }

    /// Movement s px and iris error d px per frame, worked by hand: std(s)
    /// = sqrt(10 / 4) and std(d) = 1.
    const S: [f64; 4] = [-2.0, -1.0, 1.0, 2.0];
    const D: [f64; 4] = [1.0, -1.0, 1.0, -1.0];

    /// Both eyes alike; n as read from `iris` between corners `a` and `b`
    /// (x) and a 10-px lid gap whose upper lid is at y = 0 (y).
    fn eye(a: [f64; 2], b: [f64; 2], iris: [f64; 2], drawn: [f64; 2]) -> [EyeReadBack; 2] {
        let (ux, uy) = (b[0] - a[0], b[1] - a[1]);
        let w2 = ux * ux + uy * uy;
        let e = EyeReadBack {
            iris_px: iris,
            corner_left_px: a,
            corner_right_px: b,
            aperture: 0.25,
            n: [
                ((iris[0] - a[0]) * ux + (iris[1] - a[1]) * uy) / w2,
                iris[1] / 10.0,
            ],
            drawn_iris_px: drawn,
        };
        [e, e]
    }

    /// Frame k: corners `a`, `b`; the iris read at `read(S[k])` and drawn
    /// at `read(S[k] + D[k])`.
    fn frames(a: [f64; 2], b: [f64; 2], read: impl Fn(f64) -> [f64; 2]) -> Vec<[EyeReadBack; 2]> {
        S.iter()
            .zip(D)
            .map(|(&s, d)| eye(a, b, read(s), read(s + d)))
            .collect()
    }

    #[test]
    fn budget_of_a_level_eye_worked_by_hand() {
        // 40 px wide, lid to lid 0.25 x 40 = 10 px; the iris moves s px on
        // both axes and the read is off by d px on both.
        let eyes = frames([0.0, 0.0], [40.0, 0.0], |s| [20.0 + s, 5.0 + s]);
        let source: Vec<[f64; 2]> = S
            .iter()
            .map(|&s| [0.5 + s / 40.0, 0.5 + s / 10.0])
            .collect();
        let b = read_back_budget(&source, &eyes).unwrap();
        assert_eq!(b.frames, 4);
        for axis in [b.x, b.y] {
            assert!((axis.movement_px - 2.5f64.sqrt()).abs() < 1e-12, "{b:?}");
            assert!((axis.iris_error_px - 1.0).abs() < 1e-12, "{b:?}");
            // The drawn centre moves s + d: r(s, s + d) = 8 / sqrt(10 * 10).
            assert!((axis.r_drawn_iris.unwrap() - 0.8).abs() < 1e-12, "{b:?}");
        }
    }

    #[test]
    fn budget_takes_x_along_the_corner_axis() {
        // An eye turned 90 degrees: its corner axis is the image's y, so a
        // read off on the image's x (by 3 px here) is no error along it.
        let eyes: Vec<_> = frames([0.0, 0.0], [0.0, 40.0], |s| [5.0, 20.0 + s])
            .into_iter()
            .map(|f| {
                f.map(|e| EyeReadBack {
                    drawn_iris_px: [e.drawn_iris_px[0] + 3.0, e.drawn_iris_px[1]],
                    ..e
                })
            })
            .collect();
        let source: Vec<[f64; 2]> = S.iter().map(|&s| [0.5 + s / 40.0, 0.5]).collect();
        let b = read_back_budget(&source, &eyes).unwrap();
        assert!((b.x.movement_px - 2.5f64.sqrt()).abs() < 1e-12, "{b:?}");
        assert!((b.x.iris_error_px - 1.0).abs() < 1e-12, "{b:?}");
        assert!((b.x.r_drawn_iris.unwrap() - 0.8).abs() < 1e-12, "{b:?}");
        assert_eq!(b.y.movement_px, 0.0);
    }

    #[test]
    fn budget_needs_three_matching_frames() {
        let e = eye([0.0, 0.0], [40.0, 0.0], [20.0, 5.0], [20.0, 5.0]);
        assert!(read_back_budget(&[[0.5, 0.5]; 2], &[e; 2]).is_none());
        assert!(read_back_budget(&[[0.5, 0.5]; 3], &[e; 4]).is_none());
    }
}
