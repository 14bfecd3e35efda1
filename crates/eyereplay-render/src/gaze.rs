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
//! 3. **Eye rotation.** Each rendered eye is rotated (yaw, pitch) so that its
//!    iris centre, measured in the rendered image exactly like the paper
//!    measures MediaPipe landmarks (x between the two eye corners, y between
//!    the upper- and lower-lid midpoints, with lids that follow vertical
//!    gaze), equals `n'`. This is solved numerically on the rendered eye's own
//!    projection, so the mapping holds whatever the identity and camera.
//!    Then both eyes turn nasally by the vergence angle
//!    `atan((ipd / 2) / viewing_distance)` to converge on a target at the
//!    viewing distance; the two eyes' mean `n` stays at `n'`.

use eyereplay_core::{Canvas, CanvasPos, NormPos};
use serde::{Deserialize, Serialize};

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
}

impl GazeMapping {
    pub fn new(canvas: Canvas) -> GazeMapping {
        GazeMapping {
            canvas,
            calibration: default_calibration(canvas),
            gain: 1.0,
            viewing_distance_mm: 600.0,
        }
    }

    /// Steps 1 and 2 of the model: the iris position each eye should show.
    pub fn target_norm(&self, c: CanvasPos) -> NormPos {
        let n = self.calibration.canvas_to_norm(c);
        NormPos {
            nx: 0.5 + self.gain * (n.nx - 0.5),
            ny: 0.5 + self.gain * (n.ny - 0.5),
        }
    }

    /// Nasal rotation of each eye to converge at the viewing distance.
    pub fn vergence_rad(&self, ipd_mm: f64) -> f64 {
        (0.5 * ipd_mm / self.viewing_distance_mm).atan()
    }

    pub fn validate(&self) -> Result<(), String> {
        let c = &self.calibration;
        for (name, v) in [("s_x", c.s_x), ("s_y", c.s_y)] {
            if !(v.is_finite() && v.abs() > 1e-9) {
                return Err(format!(
                    "calibration {name} must be a non-zero number, got {v}"
                ));
            }
        }
        if !(c.mu_x.is_finite() && c.mu_y.is_finite()) {
            return Err("calibration mu must be finite".into());
        }
        if !(self.gain.is_finite() && self.gain > 0.0) {
            return Err(format!("gain must be > 0, got {}", self.gain));
        }
        if !(self.viewing_distance_mm.is_finite() && self.viewing_distance_mm > 50.0) {
            return Err(format!(
                "viewing distance must be > 50 mm, got {}",
                self.viewing_distance_mm
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
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
