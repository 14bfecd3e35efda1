//! The iris model on eyes whose place is known in advance, without the face
//! detector and face mesh.
//!
//! A rendered eye close-up (eyereplay's own simulator, or another one) often
//! shows no whole face, so the face detector finds nothing; but the renderer
//! knows where each eye's corners are. [`EyeCropTracker`] places the iris
//! model's two eye crops from such corner pairs exactly as [`Tracker`](crate::Tracker) places
//! them from the face mesh's corner landmarks (square crop, side 2.3 x the
//! corner pair's extent, rotated along the corner axis, the image-right eye
//! fed mirrored) and reads the eyes the same way (iris centre, contour
//! corners and lids), so an [`Eye::measure`] from it means what one from the
//! full pipeline means.
//!
//! Two things differ from [`Tracker`](crate::Tracker), both measured on a 3000-frame
//! reading-scale render at 1280x720 against the renderer's ground truth:
//!
//! - The crop is box-filtered ([`ImageView::crop_nchw_area`]): a close-up
//!   eye is ~280 px wide, its 2.3x crop ~650 px, 10 image px per model
//!   pixel, and one bilinear sample per model pixel aliases (lashes, limbus
//!   edge). Box filtering cut the iris centre's error not explained by the
//!   pose from 1.4 / 1.8 px to 0.8 / 1.0 px (x / y) and lifted the vertical
//!   correlation with the source from 0.92 to 0.97. [`Tracker`](crate::Tracker) keeps
//!   MediaPipe's single sample (real faces are small in the frame, and its
//!   accuracy is checked against MediaPipe itself).
//! - [`EyeCropTracker::measure_video_rows`] can measure `nx` against the
//!   known, fixed corners ([`CornerReference::Fixed`]) instead of the model's
//!   contour corners, which move with the gaze on a still head.

use crate::decode::Decoder;
use crate::error::Result;
use crate::geom::{Pt, Roi};
use crate::image::ImageView;
use crate::models::Models;
use crate::output::{flag_blinks, EyeRow, Row};
use crate::profile::StageClock;
use crate::tracker::{iris_step, Eye, IRIS_INPUT};
use std::ops::ControlFlow;
use std::path::Path;

/// MediaPipe's eye crop: side = this x the larger extent of the corner pair
/// (`iris_landmark_landmarks_to_roi`: `scale_x/scale_y: 2.3`).
pub const EYE_CROP_SCALE: f32 = 2.3;

/// The two eyes' corners in upright image pixels: the image-left eye first,
/// each pair ordered (image-left corner, image-right corner).
pub type EyeCorners = [(Pt, Pt); 2];

/// Orders any two corner pairs into [`EyeCorners`]' convention.
pub fn order_eye_corners(pairs: [(Pt, Pt); 2]) -> EyeCorners {
    let mut p = pairs.map(|(a, b)| if a.x <= b.x { (a, b) } else { (b, a) });
    if p[1].0.x + p[1].1.x < p[0].0.x + p[0].1.x {
        p.swap(0, 1);
    }
    p
}

/// The iris model's crop for one eye from its two corners (image-left
/// first), as MediaPipe places it from mesh landmarks 33/133 or 362/263.
pub fn eye_crop_roi(corners: (Pt, Pt)) -> Roi {
    Roi::from_two_points(corners.0, corners.1, EYE_CROP_SCALE)
}

/// Which corners `nx` is measured against in [`EyeCropTracker::measure_video_rows`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CornerReference {
    /// The given (known, fixed) corners. Measured on a 3000-frame
    /// reading-scale render: the iris model's contour corners follow the
    /// iris (r 0.7-0.9 with its x, about 0.25 px per px), which shrank the
    /// horizontal amplitude to 0.87 of the truth.
    Fixed,
    /// The iris model's contour corners of each frame (as [`Eye::measure`]
    /// and the full pipeline on real video).
    Model,
}

/// The iris model alone, on eye crops placed from given eye corners.
pub struct EyeCropTracker {
    models: Models,
    iris_in: Vec<f32>,
    /// Sub-samples per crop pixel and axis; `None` (the default) picks one
    /// about every two image pixels ([`area_samples`]), `Some(1)` samples the crop
    /// as MediaPipe does (one bilinear sample per crop pixel).
    pub area_samples: Option<usize>,
    /// Crops each eye is read from, 1..=[`crate::MAX_IRIS_VIEWS`]
    /// ([`crate::Tracker::set_iris_views`]; clamped); 1 by default.
    pub iris_views: usize,
    /// CPU time of the crop and iris stages (off unless enabled).
    pub clock: StageClock,
}

/// Sub-samples per crop pixel and axis for a crop of `side_px` image pixels
/// into the iris model's 64: about two image pixels apart, so their
/// bilinear footprints (2 px each) tile the crop pixel. On a 3000-frame
/// reading-scale render (650-px crops) this gave the same fidelity as one
/// sample per image pixel (r 0.999 / 0.969 vs 0.999 / 0.971) at a quarter
/// of the cost.
pub fn area_samples(side_px: f32) -> usize {
    ((side_px / (2 * IRIS_INPUT) as f32).round() as usize).clamp(1, 8)
}

impl EyeCropTracker {
    pub fn new(models: Models) -> EyeCropTracker {
        EyeCropTracker {
            models,
            iris_in: vec![0.0; 2 * 3 * IRIS_INPUT * IRIS_INPUT],
            area_samples: None,
            iris_views: 1,
            clock: StageClock::new(false),
        }
    }

    /// Measures both eyes of `img` with crops placed from `corners` (see
    /// [`EyeCorners`]; use [`order_eye_corners`] if unsure). Image-left eye
    /// first.
    pub fn measure(&mut self, img: &ImageView, corners: &EyeCorners) -> Result<[Eye; 2]> {
        let rois = corners.map(eye_crop_roi);
        self.measure_rois(img, &rois)
    }

    /// Measures both eyes in explicitly given crops: `rois[0]` the
    /// image-left eye (fed as is), `rois[1]` the image-right one (fed
    /// mirrored), each crop's x axis pointing to the image's right.
    pub fn measure_rois(&mut self, img: &ImageView, rois: &[Roi; 2]) -> Result<[Eye; 2]> {
        let (eyes, _) = iris_step(
            &mut self.models,
            &mut self.iris_in,
            img,
            rois,
            rois.map(|r| {
                self.area_samples
                    .unwrap_or_else(|| area_samples(r.w.max(r.h)))
            }),
            self.iris_views,
            &mut self.clock,
        )?;
        Ok(eyes)
    }

    /// A whole static close-up (camera and head still, as in a render) as
    /// the extractor's per-frame rows: crops placed from `corners`, `nx`
    /// against the corners `corner_ref` names ([`Eye::measure_against`];
    /// `Fixed` is those `corners`, see [`CornerReference`] for why), `ny`
    /// and the aperture from the model's lids, blinks flagged by the
    /// extractor's rule ([`flag_blinks`] at `blink_ratio`). The rows' corner
    /// points are the ones `nx` used.
    pub fn measure_video_rows(
        &mut self,
        video: &Path,
        corners: &EyeCorners,
        corner_ref: CornerReference,
        max_frames: Option<usize>,
        blink_ratio: f64,
    ) -> Result<Vec<Row>> {
        let max = max_frames.unwrap_or(usize::MAX);
        let mut rows = Vec::new();
        if max == 0 {
            return Ok(rows);
        }
        let mut dec = Decoder::open(video)?;
        dec.frames(|t, img| {
            let eyes = self.measure(img, corners)?;
            let row = |k: usize| {
                let e = &eyes[k];
                let (cl, cr) = match corner_ref {
                    CornerReference::Fixed => corners[k],
                    CornerReference::Model => (e.corner_left, e.corner_right),
                };
                let m = e.measure_against(cl, cr);
                EyeRow {
                    nx: m.nx,
                    ny: m.ny,
                    aperture: m.aperture,
                    iris: e.iris,
                    corner_left: cl,
                    corner_right: cr,
                    nx_head: f64::NAN,
                }
            };
            rows.push(Row {
                frame: rows.len() as u64,
                time_s: t,
                face_score: 1.0,
                eyes: Some([row(0), row(1)]),
                blink: false,
                head: Vec::new(),
            });
            Ok(if rows.len() >= max {
                ControlFlow::Break(())
            } else {
                ControlFlow::Continue(())
            })
        })?;
        flag_blinks(&mut rows, blink_ratio);
        Ok(rows)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn corners_are_ordered_image_left_eye_first_left_corner_first() {
        let c = order_eye_corners([
            (Pt::new(1094.0, 383.0), Pt::new(811.0, 403.0)),
            (Pt::new(186.0, 383.0), Pt::new(469.0, 403.0)),
        ]);
        assert_eq!((c[0].0.x, c[0].1.x), (186.0, 469.0));
        assert_eq!((c[1].0.x, c[1].1.x), (811.0, 1094.0));
    }

    #[test]
    fn area_samples_land_about_two_image_pixels_apart() {
        assert_eq!(area_samples(650.0), 5); // 650 / 64 = 10.2 px per model px
        assert_eq!(area_samples(64.0), 1); // no reduction: MediaPipe's sampling
        assert_eq!(area_samples(10_000.0), 8); // capped
    }

    #[test]
    fn measuring_against_fixed_corners_ignores_the_models_corners() {
        let e = Eye {
            iris: Pt::new(150.0, 55.0),
            corner_left: Pt::new(120.0, 50.0),
            corner_right: Pt::new(170.0, 50.0),
            upper_lid: Pt::new(145.0, 45.0),
            lower_lid: Pt::new(145.0, 65.0),
            contour: vec![],
            iris_rim: [Pt::default(); 5],
        };
        let m = e.measure_against(Pt::new(100.0, 50.0), Pt::new(200.0, 50.0));
        assert!((m.nx - 0.5).abs() < 1e-9); // (150-100)/(200-100)
        assert!((m.ny - 0.5).abs() < 1e-9); // (55-45)/(65-45), the model's lids
        assert!((m.aperture - 0.2).abs() < 1e-9); // 20 / 100
        assert!((e.measure().nx - 0.6).abs() < 1e-9); // (150-120)/50
    }

    #[test]
    fn crop_is_mediapipes_2_3_eye_widths_centred_between_the_corners() {
        let r = eye_crop_roi((Pt::new(100.0, 50.0), Pt::new(200.0, 60.0)));
        assert_eq!((r.cx, r.cy), (150.0, 55.0));
        assert!((r.w - 230.0).abs() < 1e-3 && (r.h - 230.0).abs() < 1e-3);
        assert!((r.angle_rad - (10.0f32).atan2(100.0)).abs() < 1e-6);
    }
}
