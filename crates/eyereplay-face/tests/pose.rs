//! Head pose solved from projected landmarks of the canonical mesh.

mod common;

use eyereplay_face::{solve_pose, Camera, HeadPose};
use nalgebra::Vector3;

fn project_all(cam: &Camera, pose: &HeadPose, pts: &[Vector3<f64>]) -> Vec<[f64; 2]> {
    let (m, t) = pose.to_camera();
    pts.iter().map(|p| cam.project(m * p + t)).collect()
}

/// A known rotation and translation of the canonical mesh, projected with
/// a webcam-like camera, is recovered from the 2D points alone.
#[test]
fn recovers_known_poses_of_the_canonical_mesh() {
    let Some(mesh) = common::mesh() else { return };
    let cam = Camera::from_vfov(640, 480, 45.0);
    let all: Vec<Vector3<f64>> = mesh
        .positions_cm
        .iter()
        .map(|p| Vector3::from(p.map(f64::from)))
        .collect();
    let ones = vec![1.0; all.len()];
    let basis: Vec<usize> = mesh.procrustes.iter().map(|p| p.0 as usize).collect();
    let basis_w: Vec<f64> = mesh.procrustes.iter().map(|p| p.1 as f64).collect();
    for truth in [
        HeadPose {
            yaw_deg: 25.0,
            pitch_deg: -10.0,
            roll_deg: 8.0,
            translation_cm: [3.0, -2.0, 55.0],
        },
        HeadPose {
            yaw_deg: -35.0,
            pitch_deg: 15.0,
            roll_deg: -5.0,
            translation_cm: [-6.0, 4.0, 80.0],
        },
        HeadPose {
            translation_cm: [0.0, 0.0, 40.0],
            ..Default::default()
        },
    ] {
        let px = project_all(&cam, &truth, &all);
        // All 468 points, equal weights.
        let got = solve_pose(&cam, &all, &px, &ones, 20);
        check(&got, &truth, 0.01, 0.01);
        // MediaPipe's 33-point weighted basis.
        let model: Vec<Vector3<f64>> = basis.iter().map(|&i| all[i]).collect();
        let obs: Vec<[f64; 2]> = basis.iter().map(|&i| px[i]).collect();
        let got = solve_pose(&cam, &model, &obs, &basis_w, 20);
        check(&got, &truth, 0.01, 0.01);
    }
}

fn check(got: &HeadPose, want: &HeadPose, tol_deg: f64, tol_cm: f64) {
    let e = [
        got.yaw_deg - want.yaw_deg,
        got.pitch_deg - want.pitch_deg,
        got.roll_deg - want.roll_deg,
    ];
    assert!(
        e.iter().all(|x| x.abs() < tol_deg),
        "angles {got:?} vs {want:?}"
    );
    for k in 0..3 {
        assert!(
            (got.translation_cm[k] - want.translation_cm[k]).abs() < tol_cm,
            "translation {got:?} vs {want:?}"
        );
    }
}
