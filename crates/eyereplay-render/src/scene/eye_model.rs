//! One eye's static 3D model and its lids: where the eyeball, cornea, iris
//! and lid margins are in the head frame.
//!
//! Everything else (where the eye lands in the image, the gaze solver, the
//! shading) is built on these few millimetre measurements, so they are kept
//! apart from any pixel work. The lid curves here are the single source of
//! truth for the rendered lids, the lash placement, the lid creases and the
//! ground-truth aperture.

use super::Side;
use crate::identity::EyeShape;
use crate::math::{v3, Basis, V3};

/// Radius of curvature of the corneal cap.
pub(super) const CORNEA_RADIUS_MM: f64 = 7.8;
/// Refractive index of the cornea (and aqueous humour behind it).
pub(super) const CORNEA_INDEX: f64 = 1.376;
/// Depth of the flat iris behind the limbus plane.
const IRIS_BEHIND_LIMBUS_MM: f64 = 0.6;

/// Static geometry of one eye in the head frame.
#[derive(Clone, Debug)]
pub(super) struct EyeModel {
    pub(super) side: Side,
    pub(super) centre: V3,
    pub(super) radius_mm: f64,
    pub(super) iris_radius_mm: f64,
    /// z of the limbus plane in eye coordinates.
    pub(super) limbus_z_mm: f64,
    pub(super) cornea_centre_z_mm: f64,
    pub(super) iris_z_mm: f64,
    /// x offset of the inner and outer corner from the eye centre.
    pub(super) inner_x_mm: f64,
    pub(super) outer_x_mm: f64,
    /// y of the inner and outer corner (canthal tilt lifts the outer one).
    inner_y_mm: f64,
    outer_y_mm: f64,
    /// Exponents that put each lid's highest (lowest) point where the
    /// identity's shape says along the fissure.
    upper_exp: f64,
    lower_exp: f64,
}

/// Lid state of one eye for one frame, in millimetres.
#[derive(Clone, Copy, Debug)]
pub(super) struct LidState {
    /// Upper lid rise above, and lower lid drop below, the corner line.
    upper_mm: f64,
    lower_mm: f64,
    /// Eased blink closure, 0 open .. 1 closed.
    closure: f64,
}

impl EyeModel {
    /// The eye on `side` of the image for an identity's eye shape: the
    /// image-left eye (the subject's right) sits at `x = -ipd/2`.
    pub(super) fn new(sh: &EyeShape, side: Side) -> EyeModel {
        let limbus_z = (sh.eyeball_radius_mm.powi(2) - sh.iris_radius_mm.powi(2)).sqrt();
        let cornea_z = limbus_z - (CORNEA_RADIUS_MM.powi(2) - sh.iris_radius_mm.powi(2)).sqrt();
        let tilt = sh.canthal_tilt_deg.to_radians().tan();
        let up_exp = 0.5f64.ln() / sh.upper_peak_frac.ln();
        let lo_exp = 0.5f64.ln() / 0.56f64.ln();
        let sign = if side == Side::Left { 1.0 } else { -1.0 };
        let half = sh.fissure_width_mm / 2.0;
        EyeModel {
            side,
            centre: v3(-sign * sh.ipd_mm / 2.0, 0.0, 0.0),
            radius_mm: sh.eyeball_radius_mm,
            iris_radius_mm: sh.iris_radius_mm,
            limbus_z_mm: limbus_z,
            cornea_centre_z_mm: cornea_z,
            iris_z_mm: limbus_z - IRIS_BEHIND_LIMBUS_MM,
            inner_x_mm: sign * half,
            outer_x_mm: -sign * half,
            inner_y_mm: 0.7,
            outer_y_mm: 0.7 - sh.fissure_width_mm * tilt,
            upper_exp: up_exp,
            lower_exp: lo_exp,
        }
    }

    /// Point on a lid margin at `s` (0 inner corner, 1 outer), head frame.
    pub(super) fn lid_point(&self, s: f64, lids: &LidState, upper: bool) -> V3 {
        let x = self.inner_x_mm + s * (self.outer_x_mm - self.inner_x_mm);
        let base = self.inner_y_mm + s * (self.outer_y_mm - self.inner_y_mm);
        let lower_y = base
            + lids.lower_mm
                * (std::f64::consts::PI * s.powf(self.lower_exp))
                    .sin()
                    .max(0.0)
                    .powf(0.8);
        let y = if upper {
            let open = base
                - lids.upper_mm
                    * (std::f64::consts::PI * s.powf(self.upper_exp))
                        .sin()
                        .max(0.0)
                        .powf(0.55);
            // Closing moves the upper lid down onto the lower one.
            open + (lower_y - 0.02 - open) * lids.closure
        } else {
            lower_y
        };
        // The lids lie on the eyeball (plus their thickness); past the
        // sphere (towards the corners) they recede to the canthus.
        let r2 = self.radius_mm * self.radius_mm - x * x - y * y;
        let z = r2.max(9.0).sqrt() + 0.5;
        self.centre + v3(x, y, z)
    }

    /// The lids for a vertical gaze `pitch` (rad) and blink `closure`
    /// (0 open .. 1 closed): both follow the iris up and down by the
    /// identity's follow factors, and close with an eased blink.
    pub(super) fn lids(&self, shape: &EyeShape, pitch: f64, closure: f64) -> LidState {
        // Vertical iris displacement (mm, up positive) that the lids follow.
        let lift = self.limbus_z_mm * pitch.sin();
        let eased = closure * closure * (3.0 - 2.0 * closure);
        LidState {
            upper_mm: (shape.upper_lid_mm + shape.upper_lid_follow * lift).max(0.3),
            lower_mm: ((shape.lower_lid_mm - shape.lower_lid_follow * lift) * (1.0 - 0.15 * eased))
                .max(0.8),
            closure: eased,
        }
    }

    /// Centre of the limbus (the visible iris centre) for a gaze rotation.
    pub(super) fn iris_centre(&self, rot: &Basis) -> V3 {
        self.centre + rot.z * self.limbus_z_mm
    }
}
