//! Head pose per frame of a video, solved from the landmarks our extractor
//! finds: the check that a rendered full-face video's head motion is what
//! its ground truth says, and a source video's own head motion, which can
//! drive the rendered head instead of the eye-head coordination model
//! (`render.head_motion = "source"`).

use crate::error::Result;
use crate::mesh::CanonicalMesh;
use crate::pose::{Camera, HeadPose};
use eyereplay_extract::{Decoder, Models, Progress, Tracker};
use serde::{Deserialize, Serialize};
use std::ops::ControlFlow;
use std::path::Path;

/// Vertical field of view (deg) assumed for a source video whose camera is
/// unknown: a laptop webcam's, the middle of the face mode's default range
/// (38-48 deg). The solved rotations depend little on it (the face spans a
/// small part of the view); translations scale with it.
pub const SOURCE_VFOV_DEG: f64 = 43.0;

/// Gaussian smoothing of a source's head pose over time (s): the landmarks'
/// frame-to-frame jitter (a few tenths of a degree) would otherwise shake
/// the rendered head; head movements are slower than this.
pub const SOURCE_HEAD_SMOOTHING_S: f64 = 0.1;

/// The head pose in every frame of `video` with the frame's time (s, the
/// decoder's clock, as the extractor writes it; `None` where no face was
/// found), solved against `shape_cm` (a face's 468 points in the head
/// frame: an identity's own shape, or the canonical mesh for an unknown
/// person) by the weighted Procrustes basis of `mesh`, for a camera of
/// vertical field of view `vfov_deg`. The tracker runs the 468-landmark
/// model on every frame, and not the iris model ([`Tracker::face_mesh`]).
/// `progress` hears of the video as video 0.
pub fn video_head_poses(
    video: &Path,
    models_dir: &Path,
    mesh: &CanonicalMesh,
    shape_cm: &[[f32; 3]],
    vfov_deg: f64,
    progress: &dyn Progress,
) -> Result<Vec<(f64, Option<HeadPose>)>> {
    video_head_poses_upto(video, models_dir, mesh, shape_cm, vfov_deg, None, progress)
}

/// [`video_head_poses`] for the first `max_frames` frames of the video
/// (every frame with `None`): decoding stops there.
pub fn video_head_poses_upto(
    video: &Path,
    models_dir: &Path,
    mesh: &CanonicalMesh,
    shape_cm: &[[f32; 3]],
    vfov_deg: f64,
    max_frames: Option<usize>,
    progress: &dyn Progress,
) -> Result<Vec<(f64, Option<HeadPose>)>> {
    let mut tracker = Tracker::new(Models::load(models_dir)?, 1);
    let mut dec = Decoder::open(video)?;
    let total = match (dec.info.frames_estimate, max_frames) {
        (Some(e), Some(m)) => Some(e.min(m as u64)),
        (None, Some(m)) => Some(m as u64),
        (e, None) => e,
    };
    progress.start(0, total);
    let mut out = vec![];
    dec.frames(|t_s, img| {
        if max_frames.is_some_and(|m| out.len() >= m) {
            return Ok(ControlFlow::Break(()));
        }
        progress.advance(0, 1);
        let (w, h) = img.size();
        let cam = Camera::from_vfov(w, h, vfov_deg);
        let pose = tracker.face_mesh(img)?.map(|landmarks| {
            let px: Vec<[f64; 2]> = landmarks.iter().map(|p| [p.x as f64, p.y as f64]).collect();
            mesh.head_pose(&cam, shape_cm, &px)
        });
        out.push((t_s, pose));
        Ok(ControlFlow::Continue(()))
    })?;
    Ok(out)
}

/// A source video's head motion relative to its own rest pose (the median
/// of each component over the frames with a face), smoothed over time, to
/// be looked up at any time of the source.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SourceHeadTrack {
    /// Frame times (s), increasing.
    pub t_s: Vec<f64>,
    /// Relative pose per frame; `None` where no face was found within
    /// [`SOURCE_HEAD_SMOOTHING_S`] x 3 of the frame.
    pub rel: Vec<Option<HeadPose>>,
    /// The rest pose subtracted (camera frame).
    pub rest: HeadPose,
}

impl SourceHeadTrack {
    /// From [`video_head_poses`]' output: the median pose subtracted, then
    /// a Gaussian of `sigma_s` over the frames with a face (normalized by
    /// the weight found, so a gap narrows instead of pulling towards zero).
    /// `None` when no frame has a face.
    pub fn from_poses(poses: &[(f64, Option<HeadPose>)], sigma_s: f64) -> Option<SourceHeadTrack> {
        let found: Vec<(f64, [f64; 6])> = poses
            .iter()
            .filter_map(|(t, p)| p.as_ref().map(|p| (*t, p.components())))
            .collect();
        if found.is_empty() {
            return None;
        }
        let mut rest = [0.0; 6];
        for (k, r) in rest.iter_mut().enumerate() {
            let v: Vec<f64> = found.iter().map(|(_, c)| c[k]).collect();
            *r = eyereplay_signal::stats::median(&v).unwrap_or(0.0);
        }
        // Three sigmas, and a nanosecond so a neighbour exactly three
        // sigmas away is not lost to rounding of the frame times.
        let reach = 3.0 * sigma_s + 1e-9;
        let mut lo = 0;
        let rel = poses
            .iter()
            .map(|&(t, _)| {
                while lo < found.len() && found[lo].0 < t - reach {
                    lo += 1;
                }
                let (mut sum, mut wsum) = ([0.0; 6], 0.0);
                for (tf, c) in found[lo..].iter().take_while(|(tf, _)| *tf <= t + reach) {
                    let w = if sigma_s > 0.0 {
                        (-0.5 * ((tf - t) / sigma_s).powi(2)).exp()
                    } else {
                        f64::from(u8::from(*tf == t))
                    };
                    for k in 0..6 {
                        sum[k] += w * (c[k] - rest[k]);
                    }
                    wsum += w;
                }
                (wsum > 0.0).then(|| HeadPose::from_components(sum.map(|s| s / wsum)))
            })
            .collect();
        Some(SourceHeadTrack {
            t_s: poses.iter().map(|(t, _)| *t).collect(),
            rel,
            rest: HeadPose::from_components(rest),
        })
    }

    /// The relative pose at `t_s`, linear between the two frames around it;
    /// `None` outside the video (more than half a frame interval beyond its
    /// first or last frame) or where either neighbour has no pose.
    pub fn at(&self, t_s: f64) -> Option<HeadPose> {
        let n = self.t_s.len();
        if n == 0 {
            return None;
        }
        let half = if n > 1 {
            0.5 * (self.t_s[n - 1] - self.t_s[0]) / (n - 1) as f64
        } else {
            0.0
        };
        if t_s < self.t_s[0] - half || t_s > self.t_s[n - 1] + half {
            return None;
        }
        let j = self.t_s.partition_point(|&x| x <= t_s);
        if j == 0 {
            return self.rel[0];
        }
        if j == n {
            return self.rel[n - 1];
        }
        let (a, b) = (self.rel[j - 1]?, self.rel[j]?);
        let (t0, t1) = (self.t_s[j - 1], self.t_s[j]);
        let f = if t1 > t0 { (t_s - t0) / (t1 - t0) } else { 0.0 };
        let (ca, cb) = (a.components(), b.components());
        Some(HeadPose::from_components(std::array::from_fn(|k| {
            ca[k] + f * (cb[k] - ca[k])
        })))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pose(yaw: f64, z: f64) -> HeadPose {
        HeadPose {
            yaw_deg: yaw,
            pitch_deg: 2.0,
            roll_deg: 0.0,
            translation_cm: [0.0, 0.0, z],
        }
    }

    #[test]
    fn relative_to_the_median_and_interpolated_between_frames() {
        // Yaw 10 deg on frames 0-4, 14 on frame 5, 10 again; depth 50 cm; no
        // face on frame 7. Median rest: yaw 10, pitch 2, depth 50.
        let poses: Vec<(f64, Option<HeadPose>)> = (0..10)
            .map(|i| {
                let t = 0.04 * i as f64;
                let p = match i {
                    5 => Some(pose(14.0, 50.0)),
                    7 => None,
                    _ => Some(pose(10.0, 50.0)),
                };
                (t, p)
            })
            .collect();
        let tr = SourceHeadTrack::from_poses(&poses, 0.0).unwrap();
        assert_eq!(tr.rest, pose(10.0, 50.0));
        assert_eq!(tr.rel[5].unwrap().yaw_deg, 4.0);
        assert_eq!(tr.rel[4].unwrap().pitch_deg, 0.0);
        assert_eq!(tr.rel[7], None);
        // Halfway between frames 4 (0) and 5 (4 deg): 2 deg.
        assert!((tr.at(0.18).unwrap().yaw_deg - 2.0).abs() < 1e-9);
        // Next to the frame without a face: nothing to interpolate.
        assert_eq!(tr.at(0.27), None);
        // Outside the video.
        assert_eq!(tr.at(-0.05), None);
        assert_eq!(tr.at(0.40), None);
        assert!(tr.at(0.37).is_some());
        // Smoothing: the 4 deg spike spread by a Gaussian of sigma one frame
        // keeps its area (4 deg x 1 frame) while every frame's weights sum
        // to 1, so the frame itself gets 4 / sum_k exp(-k^2/2) over its
        // neighbours within 3 frames (frame 7 has no face).
        let sm = SourceHeadTrack::from_poses(&poses, 0.04).unwrap();
        let g = |k: f64| (-0.5 * k * k).exp();
        let w: f64 = [-3.0, -2.0, -1.0, 0.0, 1.0, 3.0]
            .iter()
            .map(|&k| g(k))
            .sum();
        assert!((sm.rel[5].unwrap().yaw_deg - 4.0 / w).abs() < 1e-6);
        assert!(
            sm.rel[7].is_some(),
            "a one-frame gap is bridged by its neighbours"
        );
        assert!(SourceHeadTrack::from_poses(&[(0.0, None)], 0.1).is_none());
    }
}
