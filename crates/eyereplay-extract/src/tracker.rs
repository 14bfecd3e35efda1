//! The per-frame pipeline: detection -> rotated face crop -> 468 landmarks
//! -> two eye crops -> iris model (or, with [`LandmarkModel::Attention`],
//! the attention face mesh reading landmarks, eyes and irises from the
//! face crop at once), with MediaPipe's tracking (the next frame's face
//! crop comes from this frame's landmarks; the detector runs again only
//! when the face score drops).

use crate::detect::{self, Detection};
use crate::error::Result;
use crate::geom::{Pt, Roi};
use crate::image::{Border, ImageView};
use crate::models::{AttentionOut, IrisOutput, LandmarkModel, Models};
use crate::profile::{Stage, StageClock};
use crate::shapes::{FACE_MESH_LANDMARKS, HEAD_POINTS};

const MESH_INPUT: usize = 192;
pub(crate) const IRIS_INPUT: usize = 64;
/// The most crops [`Tracker::set_iris_views`] reads an eye from.
pub const MAX_IRIS_VIEWS: usize = 9;
/// How far the extra iris views shift the eye crop, in the model's
/// 64-px input (so 1/32 of the crop's side, about a fifth of the iris's
/// diameter there): far enough that their errors differ, near enough that
/// the eye stays where the model expects it.
pub const IRIS_VIEW_SHIFT_PX: f32 = 2.0;
/// The views in the order they are added, as shifts along the crop's own
/// x and y axes in units of [`IRIS_VIEW_SHIFT_PX`]: the tracked crop, then
/// the four axial shifts, then the diagonals. 1, 3, 5 and 9 views are
/// symmetric about the tracked crop.
const IRIS_VIEW_OFFSETS: [(f32, f32); MAX_IRIS_VIEWS] = [
    (0.0, 0.0),
    (1.0, 0.0),
    (-1.0, 0.0),
    (0.0, 1.0),
    (0.0, -1.0),
    (1.0, 1.0),
    (-1.0, -1.0),
    (1.0, -1.0),
    (-1.0, 1.0),
];
/// MediaPipe's `min_tracking_confidence` / presence threshold.
const FACE_SCORE_MIN: f32 = 0.5;

/// Mesh indices of the eye corners that place the eye crops: the eye
/// around points 33/133 is fed as is, the one around 362/263 mirrored.
pub(crate) const EYE_CORNERS: [(usize, usize, bool); 2] = [(33, 133, false), (362, 263, true)];

/// Indices into the iris model's 71-point eye contour. Its first 16 points
/// follow the mesh's eye contour (33, 7, 163, 144, 145, 153, 154, 155, 133,
/// 246, 161, 160, 159, 158, 157, 173 for the unmirrored eye): 0 and 8 are
/// the corners, 4 the middle of the lower lid (mesh 145/374), 12 the middle
/// of the upper lid (mesh 159/386).
const CONTOUR_CORNER_A: usize = 0;
const CONTOUR_CORNER_B: usize = 8;
const CONTOUR_LOWER_LID: usize = 4;
const CONTOUR_UPPER_LID: usize = 12;

/// One eye, in upright image pixels.
#[derive(Clone, Debug, PartialEq)]
pub struct Eye {
    pub iris: Pt,
    /// The corner on the image's left and the one on its right.
    pub corner_left: Pt,
    pub corner_right: Pt,
    pub upper_lid: Pt,
    pub lower_lid: Pt,
    /// The 71 contour points and 5 iris points (centre first), for previews.
    pub contour: Vec<Pt>,
    pub iris_rim: [Pt; 5],
}

/// The paper's iris normalization for one eye, measured in the image's
/// directions: nx = 0 at the image-left corner, 1 at the image-right one;
/// ny = 0 at the upper lid, 1 at the lower lid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EyeMeasure {
    pub nx: f64,
    pub ny: f64,
    /// Lid gap over corner-to-corner width.
    pub aperture: f64,
}

impl Eye {
    /// The paper's normalization against the iris model's own contour
    /// corners and lids.
    pub fn measure(&self) -> EyeMeasure {
        self.measure_against(self.corner_left, self.corner_right)
    }

    /// `nx` (and the aperture's width) against given corners `cl`, `cr`
    /// (image-left first) instead of the model's, `ny` against the model's
    /// lids. For a camera and head that do not move (a render), the true
    /// corners are constant while the model's drift with the gaze.
    pub fn measure_against(&self, cl: Pt, cr: Pt) -> EyeMeasure {
        let (top, bot) = (self.upper_lid, self.lower_lid);
        let nx = (self.iris.x - cl.x) as f64 / (cr.x - cl.x) as f64;
        let ny = (self.iris.y - top.y) as f64 / (bot.y - top.y) as f64;
        let width = cl.dist(cr) as f64;
        let aperture = if width > 0.0 {
            top.dist(bot) as f64 / width
        } else {
            f64::NAN
        };
        EyeMeasure { nx, ny, aperture }
    }
}

/// What the pipeline found in one frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Face {
    /// Face presence probability from the landmark model.
    pub score: f32,
    /// Image-left eye first.
    pub eyes: [Eye; 2],
    /// The 468 mesh points (kept for previews only).
    pub mesh: Vec<Pt>,
    /// True when the detector ran on this frame (not tracked).
    pub detected: bool,
}

impl Face {
    /// The mesh's [`HEAD_POINTS`] (empty on frames that did not run the
    /// mesh).
    pub fn head_points(&self) -> Vec<Pt> {
        if self.mesh.len() < FACE_MESH_LANDMARKS {
            return Vec::new();
        }
        HEAD_POINTS.iter().map(|&i| self.mesh[i]).collect()
    }
}

pub struct Tracker {
    models: Models,
    anchors: Vec<[f32; 2]>,
    roi: Option<Roi>,
    det_in: Vec<f32>,
    mesh_in: Vec<f32>,
    iris_in: Vec<f32>,
    /// Number of detector runs (for statistics).
    pub detector_runs: u64,
    /// Run the face mesh on every `mesh_every`-th frame; in between, the eye
    /// crops follow the iris model's own eye corners (see [`Tracker::new`]).
    mesh_every: u32,
    /// Crops each eye is read from (see [`Tracker::set_iris_views`]).
    iris_views: usize,
    /// Which networks read the face and eyes ([`Tracker::set_landmarks`]).
    landmarks: LandmarkModel,
    since_mesh: u32,
    eye_track: Option<EyeTrack>,
    last_score: f32,
    /// CPU time per stage (`--profile`; off unless enabled).
    pub clock: StageClock,
}

impl Tracker {
    /// `mesh_every` = 1 runs MediaPipe's full pipeline on every frame. With
    /// n > 1 the face mesh runs on one frame in n; the frames in between
    /// reuse the last mesh frame's eye crops, moved with the eyes (the mesh
    /// and its crop cost about half as much as the two-eye iris inference).
    /// A frame whose eyes jump or change size falls back to the mesh.
    pub fn new(models: Models, mesh_every: u32) -> Tracker {
        Tracker {
            models,
            anchors: detect::anchors(),
            roi: None,
            det_in: vec![0.0; 3 * detect::INPUT * detect::INPUT],
            mesh_in: vec![0.0; 3 * MESH_INPUT * MESH_INPUT],
            iris_in: vec![0.0; 2 * 3 * IRIS_INPUT * IRIS_INPUT],
            detector_runs: 0,
            mesh_every: mesh_every.max(1),
            iris_views: 1,
            landmarks: LandmarkModel::Cascade,
            since_mesh: 0,
            eye_track: None,
            last_score: 0.0,
            clock: StageClock::new(false),
        }
    }

    /// Reads each eye from `views` crops instead of one (clamped to
    /// 1..=[`MAX_IRIS_VIEWS`]): the tracked crop and copies shifted by
    /// [`IRIS_VIEW_SHIFT_PX`] along its axes, all in one batched inference,
    /// each output mapped back to the image and the points averaged. The
    /// iris model's error depends on where the eye sits in its crop, and
    /// the crop moves with the tracked eye, so a single view's error drifts
    /// with the gaze and the head; averaged views cancel much of it (the
    /// docs/FACE.md, "A whole face in a webcam frame"). Costs about `views` times
    /// the iris inference. 1 (the default) is MediaPipe's single crop.
    pub fn set_iris_views(&mut self, views: usize) {
        self.iris_views = views.clamp(1, MAX_IRIS_VIEWS);
    }

    /// Reads the face and eyes with `model`. With
    /// [`LandmarkModel::Attention`] one network reads the mesh, eye
    /// contours and irises from the face crop on every frame, as
    /// MediaPipe's Python face mesh with `refine_landmarks=True` does:
    /// `mesh_every` and the iris views do not apply.
    pub fn set_landmarks(&mut self, model: LandmarkModel) {
        self.landmarks = model;
        self.reset();
    }

    /// True when the networks run on CUDA.
    pub fn on_cuda(&self) -> bool {
        self.models.on_cuda
    }

    /// Forget the tracked face (the next frame runs the detector).
    pub fn reset(&mut self) {
        self.roi = None;
        self.eye_track = None;
        self.since_mesh = 0;
    }

    /// Runs the detector; returns the largest face's ROI.
    fn detect(&mut self, img: &ImageView) -> Result<Option<Roi>> {
        self.detector_runs += 1;
        self.clock.lap(Stage::Post);
        let (w, h) = img.size();
        let lb = detect::letterbox(w, h);
        img.crop_nchw(
            &lb,
            detect::INPUT,
            false,
            Border::Black,
            1.0 / 127.5,
            -1.0,
            &mut self.det_in,
        );
        self.clock.lap(Stage::Crop);
        let raw = self.models.detect(&self.det_in)?;
        self.clock.lap(Stage::Detector);
        let dets = detect::decode(&raw.regressors, &raw.scores, &self.anchors);
        let best: Option<&Detection> = dets
            .iter()
            .max_by(|a, b| detect::area_px(a, &lb).total_cmp(&detect::area_px(b, &lb)));
        self.clock.lap(Stage::Post);
        Ok(best.map(|d| detect::face_roi(d, &lb)))
    }

    /// Processes one frame with the face mesh whatever `mesh_every` says
    /// (for preview frames, which draw the mesh).
    pub fn process_with_mesh(&mut self, img: &ImageView) -> Result<Option<Face>> {
        self.since_mesh = self.mesh_every;
        self.process(img)
    }

    /// Processes one frame.
    pub fn process(&mut self, img: &ImageView) -> Result<Option<Face>> {
        if self.landmarks == LandmarkModel::Attention {
            let Some(step) = self.mesh_step(img)? else {
                return Ok(None);
            };
            return Ok(Some(Face {
                score: step.score,
                eyes: step.eyes.expect("the attention mesh reads the eyes"),
                mesh: step.mesh,
                detected: step.detected,
            }));
        }
        if self.since_mesh + 1 < self.mesh_every {
            if let Some(t) = self.eye_track.take() {
                // The eye crops of the last mesh frame, moved by how far the
                // eyes moved since (measured on the iris model's own
                // corners, so both ends of the difference are the same
                // network's points). Cropping the iris model's corners
                // directly agreed less with MediaPipe (r_x 0.91 vs 0.93 at
                // mesh_every 2): the model's output shifts with the crop's
                // placement, so the crop definition must stay the mesh's.
                let (dx, dy) = (t.mid.x - t.base_mid.x, t.mid.y - t.base_mid.y);
                let eye_rois = t.base_rois.map(|r| Roi {
                    cx: r.cx + dx,
                    cy: r.cy + dy,
                    ..r
                });
                let eyes = self.eyes(img, eye_rois, Some((t.base_rois, t.base_mid)))?;
                if self.eyes_plausible(&t) {
                    self.since_mesh += 1;
                    // Follow the face with the eyes so the next mesh crop
                    // starts where the face is now.
                    if let (Some(roi), Some(now)) = (self.roi.as_mut(), self.eye_track.as_ref()) {
                        roi.cx += now.mid.x - t.mid.x;
                        roi.cy += now.mid.y - t.mid.y;
                    }
                    return Ok(Some(Face {
                        score: t.score,
                        eyes,
                        mesh: vec![],
                        detected: false,
                    }));
                }
                // The eyes jumped or shrank: fall back to the full pipeline
                // on this same frame.
            }
        }
        self.since_mesh = 0;
        let Some(MeshStep {
            mesh,
            score,
            detected,
            ..
        }) = self.mesh_step(img)?
        else {
            return Ok(None);
        };
        let eye_rois = EYE_CORNERS.map(|(a, b, _)| Roi::from_two_points(mesh[a], mesh[b], 2.3));
        let eyes = self.eyes(img, eye_rois, None)?;
        Ok(Some(Face {
            score,
            eyes,
            mesh,
            detected,
        }))
    }

    /// The 468 face-mesh landmarks of one frame (image px), without the
    /// iris model: for the head's pose, which needs no iris (the iris
    /// inference is about two thirds of a frame's CPU time). The same
    /// landmarks as [`Tracker::process_with_mesh`] on the same frames: the
    /// face track follows the mesh alone.
    pub fn face_mesh(&mut self, img: &ImageView) -> Result<Option<Vec<Pt>>> {
        self.since_mesh = 0;
        Ok(self.mesh_step(img)?.map(|step| step.mesh))
    }

    /// The face detector where no face is tracked, then the face mesh (or
    /// the attention mesh, with its eyes): the landmarks in image px, the
    /// face score and whether the detector ran; `None` (and no eye track)
    /// when no face is found. Moves the face track to the new landmarks.
    fn mesh_step(&mut self, img: &ImageView) -> Result<Option<MeshStep>> {
        let mut detected = false;
        loop {
            let roi = match self.roi {
                Some(r) => r,
                None => {
                    detected = true;
                    match self.detect(img)? {
                        Some(r) => r,
                        None => {
                            self.eye_track = None;
                            return Ok(None);
                        }
                    }
                }
            };
            self.clock.lap(Stage::Post);
            img.crop_nchw(
                &roi,
                MESH_INPUT,
                false,
                Border::Replicate,
                1.0 / 255.0,
                0.0,
                &mut self.mesh_in,
            );
            self.clock.lap(Stage::Crop);
            let (lm, logit, attention) = match self.landmarks {
                LandmarkModel::Cascade => {
                    let out = self.models.mesh(&self.mesh_in)?;
                    (out.landmarks, out.face_flag, None)
                }
                LandmarkModel::Attention => {
                    let mut out = self.models.attention(&self.mesh_in)?;
                    (std::mem::take(&mut out.mesh), out.face_logit, Some(out))
                }
            };
            self.clock.lap(Stage::Mesh);
            let score = 1.0 / (1.0 + (-logit).exp());
            if score < FACE_SCORE_MIN {
                self.roi = None;
                self.eye_track = None;
                if detected {
                    return Ok(None);
                }
                // Lost the track: detect again on this same frame.
                continue;
            }
            let s = MESH_INPUT as f32;
            let mesh: Vec<Pt> = lm
                .chunks_exact(3)
                .map(|p| roi.to_image(p[0] / s, p[1] / s))
                .collect();
            let eyes = attention.map(|out| attention_eyes(&out, &roi));
            let axis = (mesh[263].y - mesh[33].y).atan2(mesh[263].x - mesh[33].x);
            self.roi = Some(Roi::around_points(&mesh, axis, 1.5));
            self.last_score = score;
            self.clock.lap(Stage::Post);
            return Ok(Some(MeshStep {
                mesh,
                score,
                detected,
                eyes,
            }));
        }
    }

    /// After an iris-only frame: are the new eyes close to the previous ones
    /// (width within 25 %, midpoint moved less than half an eye width)?
    fn eyes_plausible(&self, before: &EyeTrack) -> bool {
        let Some(now) = &self.eye_track else {
            return false;
        };
        (0..2).all(|k| {
            let w0 = before.corners[k].0.dist(before.corners[k].1);
            let w1 = now.corners[k].0.dist(now.corners[k].1);
            w0 > 0.0 && (w1 / w0 - 1.0).abs() < 0.25
        }) && now.mid.dist(before.mid) < 0.5 * before.corners[0].0.dist(before.corners[0].1)
    }

    /// Runs the iris model on the two eye ROIs (model order: the eye of mesh
    /// points 33/133 unmirrored, then the one of 362/263 mirrored) and keeps
    /// the contour corners to place the next frame's eye crops.
    /// `base` is the last mesh frame's eye crops and eye midpoint; `None`
    /// when `rois` come from this frame's mesh (they become the base).
    fn eyes(
        &mut self,
        img: &ImageView,
        rois: [Roi; 2],
        base: Option<([Roi; 2], Pt)>,
    ) -> Result<[Eye; 2]> {
        let (eyes, corners) = iris_step(
            &mut self.models,
            &mut self.iris_in,
            img,
            &rois,
            [1, 1],
            self.iris_views,
            &mut self.clock,
        )?;
        let mid = Pt::new(
            (corners[0].0.x + corners[0].1.x + corners[1].0.x + corners[1].1.x) / 4.0,
            (corners[0].0.y + corners[0].1.y + corners[1].0.y + corners[1].1.y) / 4.0,
        );
        let (base_rois, base_mid) = base.unwrap_or((rois, mid));
        self.eye_track = Some(EyeTrack {
            corners,
            mid,
            base_rois,
            base_mid,
            score: self.last_score,
        });
        Ok(eyes)
    }
}

/// One face-mesh run of [`Tracker::mesh_step`].
struct MeshStep {
    /// The 468 points in image px.
    mesh: Vec<Pt>,
    score: f32,
    /// True when the detector ran on this frame.
    detected: bool,
    /// The eyes, image-left first, when the attention mesh read them.
    eyes: Option<[Eye; 2]>,
}

/// The eyes the attention mesh read from the face crop `roi` (its points
/// in the crop's 192 px), image-left first. Its eye contours follow the
/// iris model's 71-point layout, unmirrored for both eyes, so corners and
/// lids are read as in [`iris_step`].
fn attention_eyes(out: &AttentionOut, roi: &Roi) -> [Eye; 2] {
    let s = MESH_INPUT as f32;
    let in_image = |pts: &[f32]| -> Vec<Pt> {
        pts.chunks_exact(2)
            .map(|p| roi.to_image(p[0] / s, p[1] / s))
            .collect()
    };
    let mut eyes =
        [0, 1].map(|k| Eye::from_points(in_image(&out.eyes[k]), &in_image(&out.irises[k])));
    image_left_first(&mut eyes);
    eyes
}

impl Eye {
    /// An eye from the 71-point contour (the iris model's layout) and the 5
    /// iris points (centre first), in the image.
    fn from_points(contour: Vec<Pt>, rim: &[Pt]) -> Eye {
        let (a, b) = (contour[CONTOUR_CORNER_A], contour[CONTOUR_CORNER_B]);
        let (corner_left, corner_right) = if a.x <= b.x { (a, b) } else { (b, a) };
        Eye {
            iris: rim[0],
            corner_left,
            corner_right,
            upper_lid: contour[CONTOUR_UPPER_LID],
            lower_lid: contour[CONTOUR_LOWER_LID],
            iris_rim: [rim[0], rim[1], rim[2], rim[3], rim[4]],
            contour,
        }
    }
}

/// Puts the image-left eye first, whatever the head's roll or a mirrored
/// video.
fn image_left_first(eyes: &mut [Eye; 2]) {
    let mid_x = |e: &Eye| e.corner_left.x + e.corner_right.x;
    if mid_x(&eyes[1]) < mid_x(&eyes[0]) {
        eyes.swap(0, 1);
    }
}

/// Contour corners per eye in model order (crop-axis start, end).
pub(crate) type ModelCorners = [(Pt, Pt); 2];

/// The iris model on two eye crops: `rois[0]` is the eye of mesh points
/// 33/133 (fed as is), `rois[1]` the one of 362/263 (fed mirrored), each
/// crop's x axis running from the image-left corner to the image-right one.
/// Returns the eyes image-left first, and the contour corners in model order
/// (crop-axis start, end) for placing later crops. `iris_in` is the input
/// buffer (grown to 2 x `views` x 3x64x64); `area_samples[k]` > 1
/// box-filters crop `k` ([`ImageView::crop_nchw_area`]), 1 samples it as
/// MediaPipe does. `views` > 1 reads each eye from that many shifted crops
/// ([`Tracker::set_iris_views`]) and averages the points in the image; 1
/// gives exactly the single crop's points.
pub(crate) fn iris_step(
    models: &mut Models,
    iris_in: &mut Vec<f32>,
    img: &ImageView,
    rois: &[Roi; 2],
    area_samples: [usize; 2],
    views: usize,
    clock: &mut StageClock,
) -> Result<([Eye; 2], ModelCorners)> {
    clock.lap(Stage::Post);
    let views = views.clamp(1, MAX_IRIS_VIEWS);
    let plane = 3 * IRIS_INPUT * IRIS_INPUT;
    if iris_in.len() < 2 * views * plane {
        iris_in.resize(2 * views * plane, 0.0);
    }
    // Crop j = 2 v + k: view v of eye k.
    let view_rois: Vec<Roi> = IRIS_VIEW_OFFSETS[..views]
        .iter()
        .flat_map(|&(dx, dy)| rois.map(|r| shifted(r, dx, dy)))
        .collect();
    for (j, roi) in view_rois.iter().enumerate() {
        let k = j % 2;
        let out = &mut iris_in[j * plane..(j + 1) * plane];
        let mirror = EYE_CORNERS[k].2;
        if area_samples[k] > 1 {
            let n = area_samples[k];
            img.crop_nchw_area(roi, IRIS_INPUT, n, mirror, 1.0 / 255.0, 0.0, out);
        } else {
            img.crop_nchw(
                roi,
                IRIS_INPUT,
                mirror,
                Border::Replicate,
                1.0 / 255.0,
                0.0,
                out,
            );
        }
    }
    clock.lap(Stage::Crop);
    let outs = models.iris_batch(&iris_in[..2 * views * plane], 2 * views)?;
    clock.lap(Stage::Iris);
    let s = IRIS_INPUT as f32;
    let mut corners = [(Pt::default(), Pt::default()); 2];
    let mut eyes: Vec<Eye> = Vec::with_capacity(2);
    for k in 0..2 {
        let mirror = EYE_CORNERS[k].2;
        // Output `j`'s points (x, y, z per point) in the image.
        let in_image = |j: usize, pts: &[f32]| -> Vec<Pt> {
            let roi = view_rois[j];
            pts.chunks_exact(3)
                .map(|p| {
                    let u = if mirror { 1.0 - p[0] / s } else { p[0] / s };
                    roi.to_image(u, p[1] / s)
                })
                .collect()
        };
        // The mean over the views of each point (one view: the points
        // themselves, bit for bit, since x / 1 is exact).
        let mean = |part: fn(&IrisOutput) -> &[f32]| -> Vec<Pt> {
            let mut sum = in_image(k, part(&outs[k]));
            for v in 1..views {
                let j = 2 * v + k;
                for (a, b) in sum.iter_mut().zip(in_image(j, part(&outs[j]))) {
                    *a = Pt::new(a.x + b.x, a.y + b.y);
                }
            }
            let n = views as f32;
            sum.into_iter().map(|p| Pt::new(p.x / n, p.y / n)).collect()
        };
        let contour = mean(|o| &o.contour);
        let rim = mean(|o| &o.iris);
        let (a, b) = (contour[CONTOUR_CORNER_A], contour[CONTOUR_CORNER_B]);
        // Contour point 0 is the corner that sits on the crop's left in
        // the model's view: mesh 33 for the first eye, 263 (mirrored) for
        // the second; the crop axis runs 33->133 and 362->263.
        corners[k] = if mirror { (b, a) } else { (a, b) };
        eyes.push(Eye::from_points(contour, &rim));
    }
    let e1 = eyes.pop().expect("two eyes");
    let e0 = eyes.pop().expect("two eyes");
    let mut eyes = [e0, e1];
    image_left_first(&mut eyes);
    clock.lap(Stage::Post);
    Ok((eyes, corners))
}

/// `roi` moved by `dx`, `dy` times [`IRIS_VIEW_SHIFT_PX`] of the model's
/// input along the crop's own axes (so the same shift in the eye's frame
/// whatever the head's roll).
fn shifted(roi: Roi, dx: f32, dy: f32) -> Roi {
    if dx == 0.0 && dy == 0.0 {
        return roi;
    }
    let (sin, cos) = roi.angle_rad.sin_cos();
    let (ux, uy) = (
        dx * IRIS_VIEW_SHIFT_PX / IRIS_INPUT as f32 * roi.w,
        dy * IRIS_VIEW_SHIFT_PX / IRIS_INPUT as f32 * roi.h,
    );
    Roi {
        cx: roi.cx + ux * cos - uy * sin,
        cy: roi.cy + ux * sin + uy * cos,
        ..roi
    }
}

/// Eye corners of the last frame, in model order, to place the next eye
/// crops without the mesh.
#[derive(Clone, Debug)]
struct EyeTrack {
    corners: [(Pt, Pt); 2],
    base_rois: [Roi; 2],
    base_mid: Pt,
    mid: Pt,
    score: f32,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::{Planes, Rotation};

    /// A 200x120 RGB picture with something eye-like (a dark disk in a
    /// light almond) so the iris model has a structure to place.
    fn eye_picture() -> Vec<u8> {
        let (w, h) = (200usize, 120usize);
        let mut data = vec![0u8; w * h * 3];
        for y in 0..h {
            for x in 0..w {
                let (fx, fy) = (x as f32 - 100.0, y as f32 - 60.0);
                let almond = (fx / 70.0).powi(2) + (fy / 28.0).powi(2) < 1.0;
                let iris = (fx - 6.0).powi(2) + (fy + 2.0).powi(2) < 18.0f32.powi(2);
                let v = if iris {
                    40
                } else if almond {
                    225
                } else {
                    170
                };
                let px = &mut data[(y * w + x) * 3..(y * w + x) * 3 + 3];
                px.copy_from_slice(&[v, (v as f32 * 0.8) as u8, (v as f32 * 0.7) as u8]);
            }
        }
        data
    }

    /// `views` > 1 is the mean, in the image, of what one view gives for
    /// each shifted crop (batched against single inferences: within float
    /// rounding), and 1 view is the tracked crop's reading bit for bit.
    #[test]
    fn iris_views_average_the_shifted_crops() {
        let Ok(mut models) = Models::load(&crate::models::default_models_dir()) else {
            panic!("iris model missing: run scripts/setup.sh");
        };
        let data = eye_picture();
        let img = ImageView {
            planes: Planes::Rgb24 {
                data: &data,
                stride: 600,
            },
            raw_w: 200,
            raw_h: 120,
            rotation: Rotation::None,
        };
        // The same eye fed twice (as the pipeline feeds two), each crop a
        // little turned, as a tilted head gives.
        let roi = Roi {
            cx: 101.0,
            cy: 59.0,
            w: 150.0,
            h: 150.0,
            angle_rad: 0.05,
        };
        let rois = [roi, roi];
        let mut buf = vec![];
        let mut clock = StageClock::new(false);
        let mut read = |rois: &[Roi; 2], views: usize| {
            iris_step(&mut models, &mut buf, &img, rois, [1, 1], views, &mut clock)
                .unwrap()
                .0
        };
        for views in [3usize, 5] {
            let together = read(&rois, views);
            let mut mean = [Pt::default(); 2];
            for &(dx, dy) in &IRIS_VIEW_OFFSETS[..views] {
                let one = read(&rois.map(|r| shifted(r, dx, dy)), 1);
                for k in 0..2 {
                    mean[k].x += one[k].iris.x / views as f32;
                    mean[k].y += one[k].iris.y / views as f32;
                }
            }
            for k in 0..2 {
                assert!(
                    together[k].iris.dist(mean[k]) < 2e-3,
                    "{views} views, eye {k}: {:?} against the views' mean {:?}",
                    together[k].iris,
                    mean[k]
                );
            }
            // The views differ (else averaging would gain nothing).
            let single = read(&rois, 1);
            assert!(single[0].iris.dist(together[0].iris) > 1e-3);
        }
        // A shift moves the crop along its own axes by 2/64 of its side.
        let s = shifted(roi, 1.0, 0.0);
        let step = 2.0 / 64.0 * 150.0;
        assert!((s.cx - (101.0 + step * 0.05f32.cos())).abs() < 1e-4);
        assert!((s.cy - (59.0 + step * 0.05f32.sin())).abs() < 1e-4);
        // One view after several: the buffer's extra room is not read.
        let again = read(&rois, 1);
        let first = {
            let mut fresh = vec![];
            iris_step(&mut models, &mut fresh, &img, &rois, [1, 1], 1, &mut clock)
                .unwrap()
                .0
        };
        assert_eq!(again, first);
    }

    #[test]
    fn eye_measure_follows_the_paper_formula() {
        let e = Eye {
            iris: Pt::new(14.0, 11.0),
            corner_left: Pt::new(10.0, 10.0),
            corner_right: Pt::new(20.0, 10.0),
            upper_lid: Pt::new(15.0, 8.0),
            lower_lid: Pt::new(15.0, 12.0),
            contour: vec![],
            iris_rim: [Pt::default(); 5],
        };
        let m = e.measure();
        assert!((m.nx - 0.4).abs() < 1e-9); // (14-10)/(20-10)
        assert!((m.ny - 0.75).abs() < 1e-9); // (11-8)/(12-8)
        assert!((m.aperture - 0.4).abs() < 1e-9); // 4/10
    }
}
