//! Head pose, the pinhole camera, and solving the pose from landmarks.
//!
//! # Frames
//!
//! - Head frame (the canonical mesh's): centimetres, +x the subject's left
//!   (image right when facing the camera), +y up, +z out of the face.
//! - Camera frame: centimetres, +x image right, +y image down, +z forward
//!   (depth). A head at zero rotation faces the camera: head (x, y, z) maps
//!   to camera (x, -y, -z) before the translation.
//! - Image: continuous pixel coordinates, pixel (i, j) covers
//!   [i, i+1) x [j, j+1), so its centre is (i + 0.5, j + 0.5), as the
//!   extractor's landmarks.
//!
//! # Angles
//!
//! `R = Ry(yaw) * Rx(-pitch) * Rz(roll)` in the head frame: yaw > 0 turns
//! the nose toward image right (the subject's left), pitch > 0 lifts the
//! nose, roll > 0 turns the face counterclockwise as the camera sees it.

use nalgebra::{Matrix3, Rotation3, Vector3};

/// A pinhole camera (no distortion).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub width_px: usize,
    pub height_px: usize,
    pub focal_px: f64,
    /// Principal point.
    pub cx_px: f64,
    pub cy_px: f64,
}

impl Camera {
    /// A camera whose vertical field of view is `vfov_deg`, principal point
    /// at the image centre.
    pub fn from_vfov(width_px: usize, height_px: usize, vfov_deg: f64) -> Camera {
        let focal_px = height_px as f64 / 2.0 / (vfov_deg.to_radians() / 2.0).tan();
        Camera {
            width_px,
            height_px,
            focal_px,
            cx_px: width_px as f64 / 2.0,
            cy_px: height_px as f64 / 2.0,
        }
    }

    /// Camera-frame point -> image pixel.
    #[inline]
    pub fn project(&self, p: Vector3<f64>) -> [f64; 2] {
        [
            self.cx_px + self.focal_px * p.x / p.z,
            self.cy_px + self.focal_px * p.y / p.z,
        ]
    }

    /// The ray through an image pixel, as a camera-frame direction with z = 1.
    #[inline]
    pub fn ray(&self, px: [f64; 2]) -> Vector3<f64> {
        Vector3::new(
            (px[0] - self.cx_px) / self.focal_px,
            (px[1] - self.cy_px) / self.focal_px,
            1.0,
        )
    }
}

/// Head orientation and position in the camera frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct HeadPose {
    pub yaw_deg: f64,
    pub pitch_deg: f64,
    pub roll_deg: f64,
    /// Head-frame origin in the camera frame (x right, y down, z depth), cm.
    pub translation_cm: [f64; 3],
}

/// Head frame -> camera frame axes: y and z flip (the face looks at the camera).
fn flip() -> Matrix3<f64> {
    Matrix3::from_diagonal(&Vector3::new(1.0, -1.0, -1.0))
}

impl HeadPose {
    /// The pose as `[yaw, pitch, roll, x, y, z]` (deg, cm): the order of
    /// the dataset's pool head rows (`eyereplay_dataset::PoseRow`).
    pub fn components(&self) -> [f64; 6] {
        let [x, y, z] = self.translation_cm;
        [self.yaw_deg, self.pitch_deg, self.roll_deg, x, y, z]
    }

    /// The inverse of [`HeadPose::components`].
    pub fn from_components(c: [f64; 6]) -> HeadPose {
        HeadPose {
            yaw_deg: c[0],
            pitch_deg: c[1],
            roll_deg: c[2],
            translation_cm: [c[3], c[4], c[5]],
        }
    }

    /// The head's rotation in its own frame (see the module doc).
    pub fn head_rotation(&self) -> Matrix3<f64> {
        let ry = Rotation3::from_axis_angle(&Vector3::y_axis(), self.yaw_deg.to_radians());
        let rx = Rotation3::from_axis_angle(&Vector3::x_axis(), -self.pitch_deg.to_radians());
        let rz = Rotation3::from_axis_angle(&Vector3::z_axis(), self.roll_deg.to_radians());
        (ry * rx * rz).into_inner()
    }

    /// Head frame -> camera frame: `p_cam = M * p_head + t`.
    pub fn to_camera(&self) -> (Matrix3<f64>, Vector3<f64>) {
        (
            flip() * self.head_rotation(),
            Vector3::from(self.translation_cm),
        )
    }

    /// Inverse of [`HeadPose::to_camera`]: the pose whose head-to-camera
    /// map is `m` (a rotation) and `t`.
    pub fn from_camera(m: &Matrix3<f64>, t: &Vector3<f64>) -> HeadPose {
        // m = F * R with R = Ry(a) Rx(-b) Rz(c). Multiplied out, R's third
        // column is (sin a cos b, sin b, cos a cos b) and its middle row
        // (cos b sin c, cos b cos c, sin b): read the angles off those.
        let r = flip() * m; // head rotation (F is its own inverse)
        let pitch = r[(1, 2)].clamp(-1.0, 1.0).asin();
        let yaw = r[(0, 2)].atan2(r[(2, 2)]);
        let roll = r[(1, 0)].atan2(r[(1, 1)]);
        HeadPose {
            yaw_deg: yaw.to_degrees(),
            pitch_deg: pitch.to_degrees(),
            roll_deg: roll.to_degrees(),
            translation_cm: [t.x, t.y, t.z],
        }
    }
}

/// A similarity transform `p -> scale * rotation * p + translation`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Similarity {
    pub scale: f64,
    pub rotation: Matrix3<f64>,
    pub translation: Vector3<f64>,
}

/// Weighted least squares `min sum w_i |s R a_i + t - b_i|^2` over
/// rotations R (det +1), translations t and, when `with_scale`, scales s
/// (Umeyama 1991, IEEE TPAMI 13(4):376-380, with weights).
pub fn weighted_procrustes(
    a: &[Vector3<f64>],
    b: &[Vector3<f64>],
    w: &[f64],
    with_scale: bool,
) -> Similarity {
    let wsum: f64 = w.iter().sum();
    let ca = a.iter().zip(w).map(|(p, &wi)| p * wi).sum::<Vector3<f64>>() / wsum;
    let cb = b.iter().zip(w).map(|(p, &wi)| p * wi).sum::<Vector3<f64>>() / wsum;
    let mut cov = Matrix3::zeros();
    let mut var_a = 0.0;
    for ((pa, pb), &wi) in a.iter().zip(b).zip(w) {
        let (da, db) = (pa - ca, pb - cb);
        cov += wi * db * da.transpose();
        var_a += wi * da.norm_squared();
    }
    let svd = cov.svd(true, true);
    let (u, vt) = (svd.u.expect("u"), svd.v_t.expect("v_t"));
    let mut d = Matrix3::identity();
    if (u * vt).determinant() < 0.0 {
        d[(2, 2)] = -1.0;
    }
    let rotation = u * d * vt;
    let scale = if with_scale {
        (svd.singular_values.component_mul(&d.diagonal())).sum() / var_a
    } else {
        1.0
    };
    let translation = cb - scale * rotation * ca;
    Similarity {
        scale,
        rotation,
        translation,
    }
}

/// Solves the head pose from 2D landmarks (image px) of the points
/// `model_cm` (head frame), weighted by `weights`. Lu, Hager & Mjolsness's
/// orthogonal iteration (2000, IEEE TPAMI 22(6):610-622: move every model
/// point onto its landmark's line of sight, re-fit the rotation by
/// Procrustes, translation in closed form) finds the basin from a frontal
/// start; Gauss-Newton on the weighted reprojection error in pixels (the
/// maximum-likelihood pose for pixel noise) then converges quadratically.
/// The model keeps its size (scale 1), so the distance is right for a head
/// of the model's size.
pub fn solve_pose(
    camera: &Camera,
    model_cm: &[Vector3<f64>],
    landmarks_px: &[[f64; 2]],
    weights: &[f64],
    iterations: usize,
) -> HeadPose {
    assert_eq!(model_cm.len(), landmarks_px.len());
    assert_eq!(model_cm.len(), weights.len());
    // Line-of-sight projectors V = r r^T / r^T r.
    let proj: Vec<Matrix3<f64>> = landmarks_px
        .iter()
        .map(|&px| {
            let r = camera.ray(px);
            r * r.transpose() / r.norm_squared()
        })
        .collect();
    // t(R) = (sum w (I - V))^-1 sum w (V - I) R p.
    let mut a = Matrix3::zeros();
    for (v, &w) in proj.iter().zip(weights) {
        a += w * (Matrix3::identity() - v);
    }
    let a_inv = a.try_inverse().unwrap_or_else(Matrix3::identity);
    let t_of = |m: &Matrix3<f64>| {
        let mut s = Vector3::zeros();
        for ((p, v), &w) in model_cm.iter().zip(&proj).zip(weights) {
            s += w * (v - Matrix3::identity()) * (m * p);
        }
        a_inv * s
    };
    let mut m = flip();
    let mut t = t_of(&m);
    for _ in 0..iterations {
        let target: Vec<Vector3<f64>> = model_cm
            .iter()
            .zip(&proj)
            .map(|(p, v)| v * (m * p + t))
            .collect();
        m = weighted_procrustes(model_cm, &target, weights, false).rotation;
        t = t_of(&m);
    }
    let (m, t) = refine_reprojection(camera, model_cm, landmarks_px, weights, m, t);
    HeadPose::from_camera(&m, &t)
}

/// Gauss-Newton on `sum w |project(m p + t) - px|^2` over a rotation
/// increment (axis-angle, left-multiplied) and the translation.
fn refine_reprojection(
    camera: &Camera,
    model_cm: &[Vector3<f64>],
    landmarks_px: &[[f64; 2]],
    weights: &[f64],
    mut m: Matrix3<f64>,
    mut t: Vector3<f64>,
) -> (Matrix3<f64>, Vector3<f64>) {
    let f = camera.focal_px;
    for _ in 0..10 {
        let mut jtj = nalgebra::Matrix6::<f64>::zeros();
        let mut jtr = nalgebra::Vector6::<f64>::zeros();
        for ((p, px), &w) in model_cm.iter().zip(landmarks_px).zip(weights) {
            let q = m * p + t;
            if q.z <= 1e-6 {
                continue;
            }
            let uv = camera.project(q);
            let r = nalgebra::Vector2::new(uv[0] - px[0], uv[1] - px[1]);
            // d(uv)/dq for u = cx + f x / z, v = cy + f y / z.
            let iz = 1.0 / q.z;
            let dq = nalgebra::Matrix2x3::new(
                f * iz,
                0.0,
                -f * q.x * iz * iz,
                0.0,
                f * iz,
                -f * q.y * iz * iz,
            );
            // q = exp([w]x) m p + t: dq/dw = -[m p]x, dq/dt = I.
            let mp = m * p;
            let skew = Matrix3::new(0.0, -mp.z, mp.y, mp.z, 0.0, -mp.x, -mp.y, mp.x, 0.0);
            let mut j = nalgebra::Matrix2x6::<f64>::zeros();
            j.fixed_view_mut::<2, 3>(0, 0).copy_from(&(dq * -skew));
            j.fixed_view_mut::<2, 3>(0, 3).copy_from(&dq);
            jtj += w * j.transpose() * j;
            jtr += w * j.transpose() * r;
        }
        let Some(step) = jtj.lu().solve(&(-jtr)) else {
            break;
        };
        let dw = Vector3::new(step[0], step[1], step[2]);
        m = Rotation3::new(dw).into_inner() * m;
        t += Vector3::new(step[3], step[4], step[5]);
        if step.norm() < 1e-12 {
            break;
        }
    }
    (m, t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn angles_round_trip_and_directions() {
        let p = HeadPose {
            yaw_deg: 25.0,
            pitch_deg: -12.0,
            roll_deg: 7.0,
            translation_cm: [1.0, 2.0, 60.0],
        };
        let (m, t) = p.to_camera();
        let q = HeadPose::from_camera(&m, &t);
        assert!((q.yaw_deg - 25.0).abs() < 1e-9);
        assert!((q.pitch_deg + 12.0).abs() < 1e-9);
        assert!((q.roll_deg - 7.0).abs() < 1e-9);
        // Directions of the module doc: the nose (+z head) moves image-right
        // with yaw, image-up (camera -y) with pitch.
        let nose = Vector3::new(0.0, 0.0, 1.0);
        let yawed = HeadPose {
            yaw_deg: 20.0,
            ..Default::default()
        };
        assert!((yawed.to_camera().0 * nose).x > 0.3);
        let pitched = HeadPose {
            pitch_deg: 20.0,
            ..Default::default()
        };
        assert!((pitched.to_camera().0 * nose).y < -0.3);
        // Roll > 0: the head's +x (image right) turns toward image up.
        let rolled = HeadPose {
            roll_deg: 20.0,
            ..Default::default()
        };
        assert!((rolled.to_camera().0 * Vector3::x()).y < -0.3);
    }

    #[test]
    fn procrustes_recovers_a_similarity() {
        let a: Vec<Vector3<f64>> = (0..20)
            .map(|i| {
                let f = i as f64;
                Vector3::new((f * 1.3).sin() * 5.0, (f * 0.7).cos() * 4.0, f * 0.3 - 3.0)
            })
            .collect();
        let r = Rotation3::from_euler_angles(0.3, -0.5, 1.1).into_inner();
        let t = Vector3::new(3.0, -2.0, 50.0);
        let b: Vec<Vector3<f64>> = a.iter().map(|p| 1.7 * r * p + t).collect();
        let w: Vec<f64> = (0..20).map(|i| 1.0 + i as f64).collect();
        let s = weighted_procrustes(&a, &b, &w, true);
        assert!((s.scale - 1.7).abs() < 1e-9);
        assert!((s.rotation - r).norm() < 1e-9);
        assert!((s.translation - t).norm() < 1e-8);
    }
}
