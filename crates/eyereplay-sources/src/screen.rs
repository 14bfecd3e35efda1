//! From a gaze point on a screen to an iris position in the eye aperture.
//!
//! Eye-tracker sources measure where on the screen a person looked; webcam
//! sources measure where the iris sits between the eye corners and lids. To
//! put both on one calibration, screen positions are turned into normalized
//! iris positions by a two-step model:
//!
//! 1. **Screen to visual angle**: `deg = (p - screen_centre) / px_per_deg`,
//!    with `px_per_deg` given, or derived from the screen's physical width and
//!    the viewing distance: `px_per_deg = width_px / (2 atan(width_mm / 2 /
//!    distance_mm))` in degrees (defaults: a 531 mm wide 24-inch 16:9 monitor
//!    at 600 mm).
//! 2. **Angle to aperture**: `nx = 0.5 - nx_per_deg * deg_x`,
//!    `ny = 0.5 + ny_per_deg * deg_y`. The iris plane sits about 10.5 mm in
//!    front of the eye's rotation centre, so it moves 10.5 mm x sin(angle);
//!    divided by a 30 mm palpebral fissure that is 0.0061 per degree
//!    horizontally. Vertically the aperture is about 10 mm and the upper lid
//!    follows about half of the vertical rotation, giving 0.0092 per degree.
//!    The horizontal sign flips because a camera facing the reader sees a
//!    left-to-right reading sweep as right-to-left image motion, the same
//!    convention as `eyereplay extract` (nx = 0 at the image-left corner).

use eyereplay_core::{NormPos, ScreenPos};
use serde::{Deserialize, Serialize};

/// Viewing geometry of an eye-tracker recording.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ViewingGeometry {
    /// Pixels per degree of visual angle; derived from the fields below when
    /// absent.
    pub px_per_deg: Option<f64>,
    pub screen_width_mm: f64,
    pub distance_mm: f64,
}

impl Default for ViewingGeometry {
    fn default() -> Self {
        ViewingGeometry {
            px_per_deg: None,
            screen_width_mm: 531.0,
            distance_mm: 600.0,
        }
    }
}

impl ViewingGeometry {
    pub fn px_per_deg(&self, screen_width_px: f64) -> f64 {
        self.px_per_deg.unwrap_or_else(|| {
            let full_deg = 2.0
                * (self.screen_width_mm / 2.0 / self.distance_mm)
                    .atan()
                    .to_degrees();
            screen_width_px / full_deg
        })
    }
}

/// Change of normalized iris position per degree of eye rotation.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EyeGains {
    pub nx_per_deg: f64,
    pub ny_per_deg: f64,
}

impl Default for EyeGains {
    fn default() -> Self {
        EyeGains {
            nx_per_deg: 0.0061,
            ny_per_deg: 0.0092,
        }
    }
}

/// Converts a screen gaze point to a normalized iris position.
pub fn screen_to_iris(
    p: ScreenPos,
    screen_px: [f64; 2],
    px_per_deg: f64,
    gains: &EyeGains,
) -> NormPos {
    let deg_x = (p.x_px - screen_px[0] / 2.0) / px_per_deg;
    let deg_y = (p.y_px - screen_px[1] / 2.0) / px_per_deg;
    NormPos {
        nx: 0.5 - gains.nx_per_deg * deg_x,
        ny: 0.5 + gains.ny_per_deg * deg_y,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn px_per_deg_from_geometry_by_hand() {
        // 531 mm at 600 mm spans 2 atan(0.4425) = 47.7388 deg; 1920 px / 47.7388.
        let g = ViewingGeometry::default();
        assert!((g.px_per_deg(1920.0) - 40.21887).abs() < 1e-4);
    }

    #[test]
    fn ten_degrees_right_moves_iris_image_left() {
        let n = screen_to_iris(
            ScreenPos {
                x_px: 960.0 + 400.0,
                y_px: 540.0,
            },
            [1920.0, 1080.0],
            40.0,
            &EyeGains::default(),
        );
        assert!((n.nx - (0.5 - 0.061)).abs() < 1e-12);
        assert!((n.ny - 0.5).abs() < 1e-12);
    }
}
