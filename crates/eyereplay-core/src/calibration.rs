//! The paper's geometric calibration (appendix, eq. 2), shared by the stage
//! that applies it (prepare), the renderer that inverts it to reproduce the
//! source's iris amplitude, and the evaluation that maps trajectories back.

use crate::{CanvasPos, NormPos};
use serde::{Deserialize, Serialize};

/// `c = s (n - 0.5) + mu` per axis: normalized iris position to canvas px.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Calibration {
    pub s_x: f64,
    pub s_y: f64,
    pub mu_x: f64,
    pub mu_y: f64,
}

impl Calibration {
    #[inline]
    pub fn norm_to_canvas(&self, n: NormPos) -> CanvasPos {
        CanvasPos {
            x_px: self.s_x * (n.nx - 0.5) + self.mu_x,
            y_px: self.s_y * (n.ny - 0.5) + self.mu_y,
        }
    }

    /// The inverse, `n = (c - mu) / s + 0.5`.
    #[inline]
    pub fn canvas_to_norm(&self, c: CanvasPos) -> NormPos {
        NormPos {
            nx: (c.x_px - self.mu_x) / self.s_x + 0.5,
            ny: (c.y_px - self.mu_y) / self.s_y + 0.5,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formula_by_hand_and_inverse() {
        let c = Calibration {
            s_x: 1000.0,
            s_y: 500.0,
            mu_x: 640.0,
            mu_y: 360.0,
        };
        let p = c.norm_to_canvas(NormPos { nx: 0.55, ny: 0.4 });
        assert!((p.x_px - 690.0).abs() < 1e-9 && (p.y_px - 310.0).abs() < 1e-9);
        let back = c.canvas_to_norm(p);
        assert!((back.nx - 0.55).abs() < 1e-12 && (back.ny - 0.4).abs() < 1e-12);
    }
}
