//! Head pose per frame of a video, solved from the landmarks our extractor
//! finds: the check that a rendered full-face video's head motion is what
//! its ground truth says, and the measurement a source video's own head
//! motion would drive the head with.

use crate::error::Result;
use crate::mesh::CanonicalMesh;
use crate::pose::{solve_pose, Camera, HeadPose};
use eyereplay_extract::{Decoder, Models, Tracker};
use nalgebra::Vector3;
use std::ops::ControlFlow;
use std::path::Path;

/// The head pose in every frame of `video` (`None` where no face was
/// found), solved against `shape_cm` (a face's 468 points in the head
/// frame: an identity's own shape, or the canonical mesh for an unknown
/// person) by the weighted Procrustes basis of `mesh`, for a camera of
/// vertical field of view `vfov_deg`. The tracker runs the 468-landmark
/// model on every frame.
pub fn video_head_poses(
    video: &Path,
    models_dir: &Path,
    mesh: &CanonicalMesh,
    shape_cm: &[[f32; 3]],
    vfov_deg: f64,
) -> Result<Vec<Option<HeadPose>>> {
    let mut tracker = Tracker::new(Models::load(models_dir)?, 1);
    let mut dec = Decoder::open(video)?;
    let basis: Vec<usize> = mesh.procrustes.iter().map(|p| p.0 as usize).collect();
    let weights: Vec<f64> = mesh.procrustes.iter().map(|p| p.1 as f64).collect();
    let model: Vec<Vector3<f64>> = basis
        .iter()
        .map(|&i| Vector3::from(shape_cm[i].map(f64::from)))
        .collect();
    let mut out = vec![];
    dec.frames(|_, img| {
        let (w, h) = img.size();
        let cam = Camera::from_vfov(w, h, vfov_deg);
        let pose = tracker.process_with_mesh(img)?.map(|face| {
            let obs: Vec<[f64; 2]> = basis
                .iter()
                .map(|&i| [face.mesh[i].x as f64, face.mesh[i].y as f64])
                .collect();
            solve_pose(&cam, &model, &obs, &weights, 20)
        });
        out.push(pose);
        Ok(ControlFlow::Continue(()))
    })?;
    Ok(out)
}
