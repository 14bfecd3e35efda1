//! Gaze solving and ground truth: which eye rotation puts the iris where the
//! trajectory asks, and where the iris and lids then are in the image.
//!
//! Measurement works on the same projected geometry the renderer draws
//! (iris centre, lid midpoints, corners), so the normalized iris position
//! written to the truth CSV is the one a viewer of the video would measure
//! (the paper's eq. 1), and the solver inverts exactly that measurement.

use super::{EyePose, EyeTruth, Scene, Side};
use crate::math::Basis;
use eyereplay_core::NormPos;

/// Largest eye rotations the solver returns.
pub(super) const YAW_LIMIT_RAD: f64 = 0.8; // about 46 degrees
pub(super) const PITCH_LIMIT_RAD: f64 = 0.6; // about 34 degrees

impl Scene {
    /// Measures where the iris of the eye on `side` appears for a pose,
    /// normalized like the paper's eq. 1 (lids open, at the pose's vertical
    /// gaze).
    fn measure(&self, side: Side, pose: EyePose, closure: f64) -> EyeTruth {
        let e = self.eye(side);
        let m = &e.model;
        let rot = Basis::gaze(pose.yaw_rad, pose.pitch_rad);
        let iris = self.camera.project(m.iris_centre(&rot));
        let lids = m.lids(&self.identity.eye, pose.pitch_rad, closure);
        let top = self.camera.project(m.lid_point(0.5, &lids, true));
        let bot = self.camera.project(m.lid_point(0.5, &lids, false));
        let a = e.inner_corner_px;
        let b = e.outer_corner_px;
        let (xl, xr) = if a[0] < b[0] {
            (a[0], b[0])
        } else {
            (b[0], a[0])
        };
        let open = m.lids(&self.identity.eye, pose.pitch_rad, 0.0);
        let top_open = self.camera.project(m.lid_point(0.5, &open, true));
        let width = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
        EyeTruth {
            pose,
            iris_px: iris,
            norm: NormPos {
                nx: (iris[0] - xl) / (xr - xl),
                ny: (iris[1] - top_open[1]) / (bot[1] - top_open[1]),
            },
            aperture: (bot[1] - top[1]).max(0.0) / width,
        }
    }

    /// Solves the rotation of the eye on `side` so that its measured normalized iris
    /// position equals `target` (Newton's method on the rendered projection;
    /// starts from the same guess every frame so frames are independent).
    pub fn solve_pose(&self, side: Side, target: NormPos) -> EyePose {
        let m = &self.eye(side).model;
        let width_mm = (m.outer_x_mm - m.inner_x_mm).abs();
        let centre = self.measure(side, EyePose::default(), 0.0).norm;
        let mut yaw =
            (((target.nx - centre.nx) * width_mm / m.limbus_z_mm).clamp(-0.9, 0.9)).asin();
        let mut pitch = 0.0;
        let h = 1e-5;
        for _ in 0..12 {
            let p = EyePose {
                yaw_rad: yaw,
                pitch_rad: pitch,
            };
            let n0 = self.measure(side, p, 0.0).norm;
            let ex = n0.nx - target.nx;
            let ey = n0.ny - target.ny;
            if ex.abs() < 1e-10 && ey.abs() < 1e-10 {
                break;
            }
            let na = self
                .measure(
                    side,
                    EyePose {
                        yaw_rad: yaw + h,
                        ..p
                    },
                    0.0,
                )
                .norm;
            let nb = self
                .measure(
                    side,
                    EyePose {
                        pitch_rad: pitch + h,
                        ..p
                    },
                    0.0,
                )
                .norm;
            let (j11, j21) = ((na.nx - n0.nx) / h, (na.ny - n0.ny) / h);
            let (j12, j22) = ((nb.nx - n0.nx) / h, (nb.ny - n0.ny) / h);
            let det = j11 * j22 - j12 * j21;
            if det.abs() < 1e-12 {
                break;
            }
            let dyaw = (j22 * ex - j12 * ey) / det;
            let dpitch = (-j21 * ex + j11 * ey) / det;
            yaw = (yaw - dyaw).clamp(-YAW_LIMIT_RAD, YAW_LIMIT_RAD);
            pitch = (pitch - dpitch).clamp(-PITCH_LIMIT_RAD, PITCH_LIMIT_RAD);
        }
        EyePose {
            yaw_rad: yaw,
            pitch_rad: pitch,
        }
    }

    /// Both eyes' poses for one gaze target, image-left eye first: each
    /// solved with [`solve_pose`](Self::solve_pose), then turned nasally by
    /// `vergence_rad` to converge (the image-left eye turns right, +yaw).
    pub fn solve_gaze(&self, target: NormPos, vergence_rad: f64) -> [EyePose; 2] {
        Side::BOTH.map(|side| {
            let mut pose = self.solve_pose(side, target);
            pose.yaw_rad += if side == Side::Left {
                vergence_rad
            } else {
                -vergence_rad
            };
            pose
        })
    }

    /// Ground truth of the eye on `side` for a pose and lid closure.
    pub fn truth(&self, side: Side, pose: EyePose, closure: f64) -> EyeTruth {
        self.measure(side, pose, closure)
    }

    /// The upper and lower lid margins of the eye on `side` for a pose and lid
    /// closure, in image pixels from the inner corner to the outer one
    /// (`n + 1` points each): where a landmark model should find the lids.
    pub fn lid_margins_px(
        &self,
        side: Side,
        pose: EyePose,
        closure: f64,
        n: usize,
    ) -> [Vec<[f64; 2]>; 2] {
        let m = &self.eye(side).model;
        let lids = m.lids(&self.identity.eye, pose.pitch_rad, closure);
        [true, false].map(|upper| {
            (0..=n)
                .map(|i| {
                    let s = i as f64 / n.max(1) as f64;
                    self.camera.project(m.lid_point(s, &lids, upper))
                })
                .collect()
        })
    }
}
