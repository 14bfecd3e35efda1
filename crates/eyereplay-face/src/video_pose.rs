//! Head pose per frame of a video, solved from the landmarks our extractor
//! finds: the check that a rendered full-face video's head motion is what
//! its ground truth says, and the measurement a source video's own head
//! motion would drive the head with.

use crate::error::Result;
use crate::mesh::CanonicalMesh;
use crate::pose::{Camera, HeadPose};
use eyereplay_extract::{Decoder, Models, Tracker};
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
    let mut out = vec![];
    dec.frames(|_, img| {
        let (w, h) = img.size();
        let cam = Camera::from_vfov(w, h, vfov_deg);
        let pose = tracker.process_with_mesh(img)?.map(|face| {
            let px: Vec<[f64; 2]> = face.mesh.iter().map(|p| [p.x as f64, p.y as f64]).collect();
            mesh.head_pose(&cam, shape_cm, &px)
        });
        out.push(pose);
        Ok(ControlFlow::Continue(()))
    })?;
    Ok(out)
}
