//! Gaze mapping: canvas pixels -> the normalized iris position the source
//! showed -> eye rotation.
//!
//! The model, in three explicit steps:
//!
//! 1. **Calibration inverse.** `prepare` mapped the source's normalized iris
//!    position `n` (paper eq. 1: 0 at the image-left eye corner, 1 at the
//!    image-right one; 0 at the upper lid, 1 at the lower lid) to the canvas
//!    by `c = s * (n - 0.5) + mu`. We invert it: `n = (c - mu) / s + 0.5`.
//! 2. **Gain.** `n' = 0.5 + gain * (n - 0.5)`; gain 1 (the default) keeps
//!    the source's amplitude, larger values amplify the trajectory.
//!    2b. **Extractor response** (when measured, see [`ResponseMap`]): the
//!    position drawn is the one the extractor's iris model reads as `n'`.
//! 3. **Eye rotation.** Each rendered eye is rotated (yaw, pitch) so that its
//!    iris centre, measured in the rendered image exactly like the paper
//!    measures MediaPipe landmarks (x between the two eye corners, y between
//!    the upper- and lower-lid midpoints, with lids that follow vertical
//!    gaze), equals `n'`. This is solved numerically on the rendered eye's own
//!    projection, so the mapping holds whatever the identity and camera.
//!    Then both eyes turn nasally by the vergence angle
//!    `atan((ipd / 2) / viewing_distance)` to converge on a target at the
//!    viewing distance; the two eyes' mean `n` stays at `n'`.

use crate::error::RenderError;
use eyereplay_core::{Canvas, CanvasPos, NormPos};
use serde::{Deserialize, Serialize};

/// The most the iris excursion may be amplified (`gain`): past a few times
/// the eyes sit against their rotation limits, and a typo of 1e308 drew
/// them pinned there without a word.
pub const MAX_GAIN: f64 = 10.0;

/// The `prepare` calibration (canvas = s * (n - 0.5) + mu), shared with
/// the other stages.
pub use eyereplay_core::Calibration;

/// Used when no dataset metadata is at hand: the canvas centre is the eye's
/// centre, the full canvas width spans 0.5 of the eye width in `n` and the
/// full height 0.3 of the lid opening (vertical iris motion within the lids
/// is smaller because the lids follow the eye).
pub fn default_calibration(canvas: Canvas) -> Calibration {
    Calibration {
        s_x: canvas.width_px as f64 / 0.5,
        s_y: canvas.height_px as f64 / 0.3,
        mu_x: canvas.width_px as f64 / 2.0,
        mu_y: canvas.height_px as f64 / 2.0,
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct GazeMapping {
    pub canvas: Canvas,
    pub calibration: Calibration,
    /// Amplification of the normalized iris excursion around 0.5.
    pub gain: f64,
    /// Distance of the fixated target (the screen) from the eyes.
    pub viewing_distance_mm: f64,
    /// How the extractor's iris model reads this identity's rendered eye
    /// (step 2b below); `None` renders the geometric target as it is.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub extractor_response: Option<ResponseMap>,
}

/// An affine map of normalized iris positions, `m = A t + b`: what a
/// measurement (the extractor's iris model on the rendered frame) reads when
/// the renderer draws the eye at the geometric position `t`.
///
/// Step 2b of the model: the renderer's own measurement (step 3) puts the
/// lids where it draws their margins, but the iris model finds the lids of
/// some rendered identities elsewhere and with another dependence on gaze,
/// which scales the `ny` it reports (0.60-0.84 of the source's vertical
/// excursion for 5 of 12 identities). With the map measured per identity,
/// the renderer draws `A^-1 (n' - b)`, so that the extractor, the same one
/// that measured the source, reads `n'` back.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ResponseMap {
    /// Rows: measured nx, measured ny; columns: target nx, target ny.
    pub a: [[f64; 2]; 2],
    pub b: [f64; 2],
}

impl ResponseMap {
    /// Least-squares fit of `measured = A target + b` over probe pairs;
    /// `None` with fewer than 3 pairs, a singular design, or a map too far
    /// from the identity to trust (any diagonal gain outside 0.25-4, or a
    /// cross term above 0.5). Coefficients are [`rounded`](Self::rounded).
    pub fn fit(pairs: &[(NormPos, NormPos)]) -> Option<ResponseMap> {
        if pairs.len() < 3 {
            return None;
        }
        // Normal equations of [tx ty 1] -> m (3x3), one solve per output.
        let mut g = [[0.0f64; 3]; 3];
        let mut r = [[0.0f64; 3]; 2];
        for (t, m) in pairs {
            let v = [t.nx, t.ny, 1.0];
            for i in 0..3 {
                for j in 0..3 {
                    g[i][j] += v[i] * v[j];
                }
                r[0][i] += v[i] * m.nx;
                r[1][i] += v[i] * m.ny;
            }
        }
        let sol = |rhs: [f64; 3]| solve3(g, rhs);
        let (x, y) = (sol(r[0])?, sol(r[1])?);
        ResponseMap {
            a: [[x[0], x[1]], [y[0], y[1]]],
            b: [x[2], y[2]],
        }
        .checked()
    }

    /// The map as recorded (rounded), or `None` when it is implausible for
    /// an extractor reading an eye: a gain outside 0.25-4 or a cross term
    /// over 0.5. Every fitted map goes through this.
    pub fn checked(self) -> Option<ResponseMap> {
        let map = self.rounded();
        (map.faults().is_empty()).then_some(map)
    }

    /// What makes the (rounded) map implausible, each as
    /// `the vertical gain, 0.2496, is outside 0.25-4`; empty when nothing.
    pub fn faults(&self) -> Vec<String> {
        let map = self.rounded();
        let mut out = Vec::new();
        for (k, axis) in ["horizontal", "vertical"].into_iter().enumerate() {
            let g = map.a[k][k];
            if !(0.25..=4.0).contains(&g) {
                out.push(format!("the {axis} gain, {g}, is outside 0.25-4"));
            }
        }
        for (row, col) in [(0, 1), (1, 0)] {
            let c = map.a[row][col];
            if c.abs() > 0.5 {
                out.push(format!("a cross term, {c}, is over 0.5"));
            }
        }
        out
    }

    /// The same gains, with the offset set so that `origin` maps to
    /// itself: corrects the measurement's gains around a working point
    /// without moving the eye there (the measurement's constant offset is
    /// left alone, since the response is only linear near where it was
    /// probed).
    pub fn about(mut self, origin: NormPos) -> ResponseMap {
        let o = [origin.nx, origin.ny];
        for k in 0..2 {
            self.b[k] = o[k] - self.a[k][0] * o[0] - self.a[k][1] * o[1];
        }
        self.rounded()
    }

    /// Coefficients rounded to 1e-4, so that a last-bit difference in a
    /// measurement cannot change the video or the identity file.
    pub fn rounded(mut self) -> ResponseMap {
        let q = |v: &mut f64| *v = (*v * 1e4).round() / 1e4;
        self.a.iter_mut().flatten().for_each(q);
        self.b.iter_mut().for_each(q);
        self
    }

    /// `self` after `first`: the map `t -> self.apply(first.apply(t))`.
    pub fn after(&self, first: &ResponseMap) -> ResponseMap {
        let (a2, a1) = (self.a, first.a);
        let mut a = [[0.0; 2]; 2];
        let mut b = [0.0; 2];
        for i in 0..2 {
            for j in 0..2 {
                a[i][j] = a2[i][0] * a1[0][j] + a2[i][1] * a1[1][j];
            }
            b[i] = a2[i][0] * first.b[0] + a2[i][1] * first.b[1] + self.b[i];
        }
        ResponseMap { a, b }
    }

    /// What the measurement reads for a drawn position `t`.
    pub fn apply(&self, t: NormPos) -> NormPos {
        NormPos {
            nx: self.a[0][0] * t.nx + self.a[0][1] * t.ny + self.b[0],
            ny: self.a[1][0] * t.nx + self.a[1][1] * t.ny + self.b[1],
        }
    }

    /// The position to draw so that the measurement reads `m`.
    pub fn invert(&self, m: NormPos) -> NormPos {
        let [nx, ny] = self.solve_linear([m.nx - self.b[0], m.ny - self.b[1]]);
        NormPos { nx, ny }
    }

    /// `A^-1 v`: how far to move the drawn position for the measurement to
    /// move by `v` (the offset `b` plays no part in a difference).
    pub fn solve_linear(&self, v: [f64; 2]) -> [f64; 2] {
        let [[a, b], [c, d]] = self.a;
        let det = a * d - b * c;
        [(d * v[0] - b * v[1]) / det, (-c * v[0] + a * v[1]) / det]
    }
}

/// Probe targets for measuring a [`ResponseMap`]: an even `n_x` x `n_y`
/// grid (nx outer, ny inner) over the 5th-95th percentile of a session's
/// own `targets` per axis (where the response matters for this session;
/// reaching the 1st-99th made the full-face mode's read-back worse: the
/// extremes answer less linearly), at least `min_span` wide so a session
/// that hardly moves still gets a well-conditioned fit; and the grid's
/// centre.
pub fn probe_grid(
    targets: &[NormPos],
    n_x: usize,
    n_y: usize,
    min_span: f64,
) -> (Vec<NormPos>, NormPos) {
    let span = |v: Vec<f64>| -> (f64, f64) {
        let q = |p: f64| eyereplay_signal::stats::quantile(&v, p).unwrap_or(0.5);
        let (lo, hi) = (q(0.05), q(0.95));
        let mid = 0.5 * (lo + hi);
        let half = (0.5 * (hi - lo)).max(0.5 * min_span);
        (mid - half, mid + half)
    };
    let (x0, x1) = span(targets.iter().map(|t| t.nx).collect());
    let (y0, y1) = span(targets.iter().map(|t| t.ny).collect());
    let step = |a: f64, b: f64, i: usize, n: usize| a + (b - a) * i as f64 / (n.max(2) - 1) as f64;
    let grid = (0..n_x)
        .flat_map(|i| {
            (0..n_y).map(move |j| NormPos {
                nx: step(x0, x1, i, n_x),
                ny: step(y0, y1, j, n_y),
            })
        })
        .collect();
    let centre = NormPos {
        nx: 0.5 * (x0 + x1),
        ny: 0.5 * (y0 + y1),
    };
    (grid, centre)
}

/// Solves a 3x3 system by Cramer's rule; `None` when singular.
fn solve3(m: [[f64; 3]; 3], r: [f64; 3]) -> Option<[f64; 3]> {
    let det = |m: [[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(m);
    if d.abs() < 1e-12 {
        return None;
    }
    let mut out = [0.0; 3];
    for (k, o) in out.iter_mut().enumerate() {
        let mut mk = m;
        for i in 0..3 {
            mk[i][k] = r[i];
        }
        *o = det(mk) / d;
    }
    Some(out)
}

impl GazeMapping {
    pub fn new(canvas: Canvas) -> GazeMapping {
        GazeMapping {
            canvas,
            calibration: default_calibration(canvas),
            gain: 1.0,
            viewing_distance_mm: 600.0,
            extractor_response: None,
        }
    }

    /// Steps 1 and 2 of the model: the iris position each eye should show.
    pub fn target_norm(&self, c: CanvasPos) -> NormPos {
        let n = self.calibration.canvas_to_norm(c);
        let n = NormPos {
            nx: 0.5 + self.gain * (n.nx - 0.5),
            ny: 0.5 + self.gain * (n.ny - 0.5),
        };
        match &self.extractor_response {
            Some(r) => r.invert(n),
            None => n,
        }
    }

    /// Nasal rotation of each eye to converge at the viewing distance.
    pub fn vergence_rad(&self, ipd_mm: f64) -> f64 {
        (0.5 * ipd_mm / self.viewing_distance_mm).atan()
    }

    /// Rejects a calibration, gain or viewing distance that cannot map gaze
    /// (as [`RenderError::Params`]).
    pub fn validate(&self) -> Result<(), RenderError> {
        let c = &self.calibration;
        for (name, v) in [("s_x", c.s_x), ("s_y", c.s_y)] {
            if !(v.is_finite() && v.abs() > 1e-9) {
                return Err(RenderError::Params(format!(
                    "calibration {name} must be a non-zero number, got {v}"
                )));
            }
        }
        if !(c.mu_x.is_finite() && c.mu_y.is_finite()) {
            return Err(RenderError::Params("calibration mu must be finite".into()));
        }
        if !(self.gain > 0.0 && self.gain <= MAX_GAIN) {
            return Err(RenderError::Params(format!(
                "gain must be above 0 and at most {MAX_GAIN}, got {}",
                eyereplay_core::show_number(self.gain)
            )));
        }
        if !(self.viewing_distance_mm.is_finite() && self.viewing_distance_mm > 50.0) {
            return Err(RenderError::Params(format!(
                "viewing distance must be > 50 mm, got {}",
                self.viewing_distance_mm
            )));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn n(nx: f64, ny: f64) -> NormPos {
        NormPos { nx, ny }
    }

    #[test]
    fn probe_grid_spans_the_quantiles_or_the_smallest_span() {
        // nx = i / 200 for i = 0..=100: the q-quantile is q / 2 exactly
        // (positions fall on samples); ny is constant, so its span is the
        // smallest allowed, about its value.
        let targets: Vec<NormPos> = (0..=100).map(|i| n(i as f64 / 200.0, 0.3)).collect();
        {
            let (lo, hi) = (0.025, 0.475);
            let (grid, centre) = probe_grid(&targets, 3, 2, 0.08);
            assert_eq!(grid.len(), 6);
            let xs: Vec<f64> = grid.iter().map(|g| g.nx).collect();
            let ys: Vec<f64> = grid.iter().map(|g| g.ny).collect();
            let mid = 0.5 * (lo + hi);
            for (got, want) in xs.iter().zip([lo, lo, mid, mid, hi, hi]) {
                assert!((got - want).abs() < 1e-12, "nx {got} vs {want}");
            }
            for (got, want) in ys.iter().zip([0.26, 0.34, 0.26, 0.34, 0.26, 0.34]) {
                assert!((got - want).abs() < 1e-12, "ny {got} vs {want}");
            }
            assert!((centre.nx - mid).abs() < 1e-12 && (centre.ny - 0.3).abs() < 1e-12);
        }
    }

    #[test]
    fn response_fit_recovers_an_affine_map_and_inverts_it() {
        // m = A t + b with A = [[1.1, 0.05], [-0.02, 0.6]], b = (-0.03, 0.21)
        let truth = ResponseMap {
            a: [[1.1, 0.05], [-0.02, 0.6]],
            b: [-0.03, 0.21],
        };
        let pairs: Vec<_> = (0..5)
            .flat_map(|i| (0..7).map(move |j| n(0.4 + 0.05 * i as f64, 0.38 + 0.03 * j as f64)))
            .map(|t| (t, truth.apply(t)))
            .collect();
        let fit = ResponseMap::fit(&pairs).expect("well posed");
        for k in 0..2 {
            assert!((fit.b[k] - truth.b[k]).abs() < 1e-4);
            for j in 0..2 {
                assert!((fit.a[k][j] - truth.a[k][j]).abs() < 1e-4);
            }
        }
        // Drawing at invert(m) makes the measurement read m.
        let m = n(0.47, 0.52);
        let back = truth.apply(truth.invert(m));
        assert!((back.nx - m.nx).abs() < 1e-12 && (back.ny - m.ny).abs() < 1e-12);
        // Moving the drawn position by solve_linear(v) moves the reading by v.
        let v = [0.013, -0.008];
        let [dx, dy] = truth.solve_linear(v);
        let moved = truth.apply(n(m.nx + dx, m.ny + dy));
        let base = truth.apply(m);
        assert!((moved.nx - base.nx - v[0]).abs() < 1e-12);
        assert!((moved.ny - base.ny - v[1]).abs() < 1e-12);
    }

    #[test]
    fn response_about_a_point_keeps_gains_and_fixes_the_point() {
        let r = ResponseMap {
            a: [[1.0, 0.0], [0.0, 0.5]],
            b: [0.0, 0.3],
        }
        .about(n(0.5, 0.45));
        assert_eq!(r.a, [[1.0, 0.0], [0.0, 0.5]]);
        let o = r.apply(n(0.5, 0.45));
        assert!((o.nx - 0.5).abs() < 1e-4 && (o.ny - 0.45).abs() < 1e-4);
        // ny 0.05 above the point reads 0.025 above it: gain 0.5, so the
        // renderer draws 0.1 above to be read 0.05 above.
        let d = r.invert(n(0.5, 0.50));
        assert!((d.ny - 0.55).abs() < 1e-3, "{d:?}");
    }

    #[test]
    fn response_after_composes_in_order() {
        let first = ResponseMap {
            a: [[2.0, 0.0], [0.0, 1.0]],
            b: [0.1, 0.0],
        };
        let second = ResponseMap {
            a: [[1.0, 1.0], [0.0, 3.0]],
            b: [0.0, -0.2],
        };
        let both = second.after(&first);
        let t = n(0.3, 0.4);
        let want = second.apply(first.apply(t));
        let got = both.apply(t);
        assert!((got.nx - want.nx).abs() < 1e-12 && (got.ny - want.ny).abs() < 1e-12);
    }

    #[test]
    fn response_fit_refuses_degenerate_or_implausible_probes() {
        let t = [n(0.4, 0.4), n(0.5, 0.4), n(0.6, 0.4)]; // ny never varies
        let pairs: Vec<_> = t.iter().map(|&t| (t, t)).collect();
        assert!(ResponseMap::fit(&pairs).is_none());
        assert!(ResponseMap::fit(&pairs[..2]).is_none());
        // A gain of 10 is not a rendered eye read by an iris model.
        let wild: Vec<_> = (0..9)
            .map(|k| n(0.4 + 0.02 * (k % 3) as f64, 0.4 + 0.02 * (k / 3) as f64))
            .map(|t| (t, n(t.nx, 10.0 * t.ny)))
            .collect();
        assert!(ResponseMap::fit(&wild).is_none());
    }

    #[test]
    fn mapping_draws_through_the_response_inverse() {
        let mut g = GazeMapping::new(Canvas::default());
        let c = CanvasPos {
            x_px: 700.0,
            y_px: 300.0,
        };
        let plain = g.target_norm(c);
        let r = ResponseMap {
            a: [[1.0, 0.0], [0.0, 0.5]],
            b: [0.0, 0.25],
        };
        g.extractor_response = Some(r);
        let drawn = g.target_norm(c);
        let read = r.apply(drawn);
        assert!((read.nx - plain.nx).abs() < 1e-12 && (read.ny - plain.ny).abs() < 1e-12);
        // An identity file without the field reads as before.
        let json = r#"{"canvas":{"width_px":1280,"height_px":720},"calibration":{"s_x":1.0,"s_y":1.0,"mu_x":0.0,"mu_y":0.0},"gain":1.0,"viewing_distance_mm":600.0}"#;
        let old: GazeMapping = serde_json::from_str(json).unwrap();
        assert_eq!(old.extractor_response, None);
    }
    #[test]
    fn calibration_inverse_roundtrips_and_gain_scales() {
        let cal = Calibration {
            s_x: 5120.0,
            s_y: 3000.0,
            mu_x: 600.0,
            mu_y: 380.0,
        };
        let n = cal.canvas_to_norm(CanvasPos {
            x_px: 600.0 + 512.0,
            y_px: 380.0 - 300.0,
        });
        assert!((n.nx - 0.6).abs() < 1e-12 && (n.ny - 0.4).abs() < 1e-12);
        let back = cal.norm_to_canvas(n);
        assert!((back.x_px - 1112.0).abs() < 1e-9);
        let mut g = GazeMapping::new(Canvas::default());
        g.calibration = cal;
        g.gain = 2.0;
        let t = g.target_norm(CanvasPos {
            x_px: 1112.0,
            y_px: 80.0,
        });
        assert!((t.nx - 0.7).abs() < 1e-12 && (t.ny - 0.3).abs() < 1e-12);
        // 63 mm IPD at 600 mm: atan(31.5/600) = 3.005 degrees.
        assert!((g.vergence_rad(63.0).to_degrees() - 3.0053).abs() < 1e-3);
    }
}
