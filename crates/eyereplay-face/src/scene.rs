//! One frame of the full-face mode: the photo's surroundings, the textured
//! face mesh under the frame's head pose, and the ray-traced eyeballs seen
//! through the face's own lid opening ([`FaceScene::draw`]).
//!
//! # Drawing order
//!
//! 1. **Backdrop.** The photo itself, mapped into the output frame by a 2D
//!    similarity fitted once (the face's landmarks at the rest pose against
//!    their photo positions), gives neck, clothes and room. Around the
//!    head (a soft ellipse covering hair and neck) it follows the head's
//!    own image motion, a similarity fitted per frame to the skirt's outer
//!    edge (below); the room beyond stays still. Past the photo's edges it
//!    is mirrored.
//! 2. **Face.** The photo-textured mesh ([`PhotoIdentity::textured_mesh`]
//!    with the eye-opening triangles dropped) plus a receding skirt around
//!    the face oval textured from the photo (jaw, ears, hair: [`with_skirt`];
//!    its outer edge samples the photo where the backdrop does at rest:
//!    [`FaceScene::skirt_onto_backdrop`]) under the frame's head pose; its
//!    lid vertices move with the eye's vertical rotation and close in
//!    blinks ([`LidRig`]), the skin next to the lids following part of the
//!    way. The outline is feathered into the
//!    backdrop.
//! 3. **Eyes.** Every pixel inside a lid opening that the face left
//!    uncovered is a ray traced into that eye's eyeball: the same cornea,
//!    iris and sclera as the close-up renderer ([`Eyeball`]), placed behind
//!    the photo's lid contour and turned by the frame's eye-in-head angles,
//!    darkened under the upper lid and toward the corners.

use crate::lm;
use crate::mesh::{CanonicalMesh, LEFT_EYE_CONTOUR, RIGHT_EYE_CONTOUR};
use crate::photo::PhotoIdentity;
use crate::pose::{Camera, HeadPose};
use crate::raster::{Rasterizer, RgbImage, TexturedMesh};
use eyereplay_render::math::{f3, v3, Basis, SrgbLut, V3};
use eyereplay_render::{EyePose, Eyeball, Identity};
use nalgebra::Vector3;
use rayon::prelude::*;

/// Depth of the eyeball centre behind the mean of its lid contour, cm: the
/// lids rest on the globe, so the corneal apex (13.2 mm from the centre of
/// a 12 mm eye) stands about 2 mm in front of the lid margins.
const EYE_CENTRE_BEHIND_LIDS_CM: f64 = 1.1;
/// The eye-in-head rotation the solver allows (deg): the human
/// oculomotor range is about +-50-55 deg (Guitton & Volle 1987); a frontal
/// photo's lid opening is reached well before that.
pub const EYE_LIMIT_DEG: f64 = 50.0;
/// How much of a lid vertex's motion the skin next to it follows.
const UPPER_SKIN_FOLLOW: f32 = 0.45;
const LOWER_SKIN_FOLLOW: f32 = 0.3;

/// The lids of one eye as mesh vertex ids.
#[derive(Clone, Debug)]
struct LidRig {
    /// The corners on the image's left and right (at the rest pose).
    corner_left: u32,
    corner_right: u32,
    /// Upper and lower lid margins, paired, from the inner corner outward.
    upper: [u32; 7],
    lower: [u32; 7],
    /// Skin vertices next to the lids: (vertex, lid index, upper lid?).
    skin: Vec<(u32, usize, bool)>,
}

impl LidRig {
    /// The rig of a contour ordered as MediaPipe's (outer corner, lower lid
    /// outward-in, inner corner, upper lid inward-out).
    fn new(mesh: &CanonicalMesh, contour: &[u32; 16], image_left_is_outer: bool) -> LidRig {
        let upper: [u32; 7] = std::array::from_fn(|k| contour[9 + k]);
        let lower: [u32; 7] = std::array::from_fn(|k| contour[7 - k]);
        let (outer, inner) = (contour[0], contour[8]);
        let fill = mesh.eye_fill_triangles();
        let mut skin: Vec<(u32, usize, bool)> = vec![];
        for (ti, t) in mesh.triangles.iter().enumerate() {
            if fill.contains(&ti) {
                continue;
            }
            for (lid, is_upper) in [(&upper, true), (&lower, false)] {
                for (k, &v) in lid.iter().enumerate() {
                    if !t.contains(&v) {
                        continue;
                    }
                    for &u in t {
                        if contour.contains(&u) || skin.iter().any(|s| s.0 == u) {
                            continue;
                        }
                        skin.push((u, k, is_upper));
                    }
                }
            }
        }
        skin.sort();
        let (corner_left, corner_right) = if image_left_is_outer {
            (outer, inner)
        } else {
            (inner, outer)
        };
        LidRig {
            corner_left,
            corner_right,
            upper,
            lower,
            skin,
        }
    }
}

/// Everything about one eye that a frame's state does not change.
#[derive(Clone, Debug)]
struct EyeSetup {
    rig: LidRig,
    /// Eyeball centre, head frame (cm).
    centre_cm: Vector3<f64>,
}

/// One frame's state of the head, eyes and lids.
#[derive(Clone, Copy, Debug, Default)]
pub struct FaceState {
    pub head: HeadPose,
    /// Eye-in-head rotation, image-left eye first (yaw > 0 looks toward
    /// image right, pitch > 0 up, as [`eyereplay_render::EyePose`]).
    pub eyes: [EyePose; 2],
    /// 0 open .. 1 closed (eased).
    pub closure: f64,
    pub pupil_scale: f64,
}

/// Where an eye's iris and aperture landmarks land in the image for one
/// state: what a landmark model should measure.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct EyeImage {
    pub iris_px: [f64; 2],
    pub corner_left_px: [f64; 2],
    pub corner_right_px: [f64; 2],
    /// The lids straight above and below the iris centre.
    pub upper_px: [f64; 2],
    pub lower_px: [f64; 2],
}

impl EyeImage {
    /// `(nx, ny, aperture)` as the extractor defines them (see
    /// eyereplay-extract's crate docs).
    pub fn norm(&self) -> (f64, f64, f64) {
        let nx = (self.iris_px[0] - self.corner_left_px[0])
            / (self.corner_right_px[0] - self.corner_left_px[0]);
        let ny = (self.iris_px[1] - self.upper_px[1]) / (self.lower_px[1] - self.upper_px[1]);
        let w = ((self.corner_right_px[0] - self.corner_left_px[0]).powi(2)
            + (self.corner_right_px[1] - self.corner_left_px[1]).powi(2))
        .sqrt();
        (nx, ny, (self.lower_px[1] - self.upper_px[1]).max(0.0) / w)
    }
}

/// An eye's lid opening in the image for one state: its corners and its
/// posed lid margins (each from the inner corner outward).
#[derive(Clone, Copy, Debug)]
struct Opening {
    corner_left: [f64; 2],
    corner_right: [f64; 2],
    upper: [[f64; 2]; 7],
    lower: [[f64; 2]; 7],
}

impl Opening {
    fn points(&self) -> impl Iterator<Item = [f64; 2]> + '_ {
        [self.corner_left, self.corner_right]
            .into_iter()
            .chain(self.upper)
            .chain(self.lower)
    }

    /// The upper (or lower) lid's image y at image x: the polyline through
    /// the corners and that lid's points, ordered by x; the end point's y
    /// beyond it.
    fn lid_y_at(&self, upper: bool, x: f64) -> f64 {
        let mut l = [[0.0f64; 2]; 9];
        l[0] = self.corner_left;
        l[1] = self.corner_right;
        l[2..].copy_from_slice(if upper { &self.upper } else { &self.lower });
        l.sort_by(|a, b| a[0].total_cmp(&b[0]));
        for s in l.windows(2) {
            if x >= s[0][0] && x <= s[1][0] {
                let t = (x - s[0][0]) / (s[1][0] - s[0][0]).max(1e-9);
                return s[0][1] + t * (s[1][1] - s[0][1]);
            }
        }
        if x < l[0][0] {
            l[0][1]
        } else {
            l[8][1]
        }
    }

    fn width_px(&self) -> f64 {
        let (a, b) = (self.corner_left, self.corner_right);
        ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt()
    }
}

/// Framing of the output video.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Framing {
    pub width: usize,
    pub height: usize,
    pub vfov_deg: f64,
    /// Forehead-to-chin height over the frame height at the rest pose.
    pub face_height_frac: f64,
    /// Key light direction in the head frame (toward the light).
    pub light_dir: [f64; 3],
}

/// An identity ready to draw frames at one size.
pub struct FaceScene {
    pub identity: PhotoIdentity,
    pub camera: Camera,
    /// The head's pose with nothing moving: the photo's rotation, framed
    /// by [`Framing`].
    pub rest_pose: HeadPose,
    /// The eyeball's identity (iris and sclera textures, eye geometry).
    pub eye_identity: Identity,
    eyeball: Eyeball,
    /// Per-channel factor on the eyeball's linear colour, so its sclera
    /// comes out as bright and as tinted as the photo's own sclera (the
    /// photo's exposure and light, not the eye model's).
    eye_gain: [f32; 3],
    /// Forehead-to-chin over the frame height at the rest pose: the
    /// framing's, or more where the photo is small around the face.
    pub face_frac: f64,
    mesh: TexturedMesh,
    eyes: [EyeSetup; 2],
    lid_follow: (f64, f64),
    light_head: Vector3<f64>,
    lut: SrgbLut,
    backdrop: Backdrop,
}

/// The photo mapped into the frame (see the module docs).
struct Backdrop {
    /// Output pixel -> photo pixel at the rest pose: `p -> a p + b` with
    /// `a` a complex number (scale and rotation).
    to_photo: Sim2,
    /// The static backdrop, sRGB.
    still: Vec<u8>,
    /// Per pixel, how much it follows the head (0 room .. 1 head).
    weight: Vec<f32>,
    /// Rows and columns where `weight > 0`.
    moving_box: [usize; 4],
    /// Mesh vertices whose projections fit the head's image motion.
    anchors: Vec<usize>,
    rest_anchors_px: Vec<[f64; 2]>,
}

/// A 2D similarity `p -> (ar + i ai) p + (bx + i by)` in complex form.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Sim2 {
    ar: f64,
    ai: f64,
    bx: f64,
    by: f64,
}

impl Sim2 {
    const IDENTITY: Sim2 = Sim2 {
        ar: 1.0,
        ai: 0.0,
        bx: 0.0,
        by: 0.0,
    };

    /// Least-squares similarity taking `from` onto `to`.
    fn fit(from: &[[f64; 2]], to: &[[f64; 2]]) -> Sim2 {
        let n = from.len().max(1) as f64;
        let mf = from
            .iter()
            .fold([0.0, 0.0], |a, p| [a[0] + p[0] / n, a[1] + p[1] / n]);
        let mt = to
            .iter()
            .fold([0.0, 0.0], |a, p| [a[0] + p[0] / n, a[1] + p[1] / n]);
        let (mut sr, mut si, mut ss) = (0.0, 0.0, 0.0);
        for (p, q) in from.iter().zip(to) {
            let (px, py) = (p[0] - mf[0], p[1] - mf[1]);
            let (qx, qy) = (q[0] - mt[0], q[1] - mt[1]);
            // sum conj(p) q and |p|^2
            sr += px * qx + py * qy;
            si += px * qy - py * qx;
            ss += px * px + py * py;
        }
        if ss <= 0.0 {
            return Sim2::IDENTITY;
        }
        let (ar, ai) = (sr / ss, si / ss);
        Sim2 {
            ar,
            ai,
            bx: mt[0] - (ar * mf[0] - ai * mf[1]),
            by: mt[1] - (ai * mf[0] + ar * mf[1]),
        }
    }

    fn apply(&self, p: [f64; 2]) -> [f64; 2] {
        [
            self.ar * p[0] - self.ai * p[1] + self.bx,
            self.ai * p[0] + self.ar * p[1] + self.by,
        ]
    }
}

/// Where an output pixel samples the photo in one frame: `S0(p) + weight(p)
/// E(p)`, with `S0` the rest pose's output-to-photo map and `E(p) =
/// S0(back(p)) - S0(p)` the head's image motion `back` (current -> rest)
/// carried into the photo; `E` is affine in `p` too, so both are a few f32
/// multiply-adds per pixel.
struct Warp {
    s0: [f32; 4],
    e: [f32; 4],
}

impl Warp {
    fn new(s0: Sim2, back: Sim2) -> Warp {
        // E's linear part is A0 (B - I), its offset A0 b (complex products).
        let (ar, ai) = (back.ar - 1.0, back.ai);
        let e = Sim2 {
            ar: s0.ar * ar - s0.ai * ai,
            ai: s0.ar * ai + s0.ai * ar,
            bx: s0.ar * back.bx - s0.ai * back.by,
            by: s0.ai * back.bx + s0.ar * back.by,
        };
        let f = |m: Sim2| [m.ar as f32, m.ai as f32, m.bx as f32, m.by as f32];
        Warp { s0: f(s0), e: f(e) }
    }

    /// The photo's colour for output pixel centre (px, py) following the
    /// head by `weight` (mirrored past the photo's edges).
    #[inline(always)]
    fn sample(&self, tex: &RgbImage, px: f32, py: f32, weight: f32) -> [f32; 3] {
        let [x, y] = self.photo_px(tex, px, py, weight);
        tex.sample(x, y)
    }

    /// [`Warp::sample`] rounded to bytes.
    #[inline(always)]
    fn sample_rgb8(&self, tex: &RgbImage, px: f32, py: f32, weight: f32) -> [u8; 3] {
        let [x, y] = self.photo_px(tex, px, py, weight);
        tex.sample_rgb8(x, y)
    }

    /// Where output pixel centre (px, py) reads the photo.
    #[inline(always)]
    fn photo_px(&self, tex: &RgbImage, px: f32, py: f32, weight: f32) -> [f32; 2] {
        let ([sr, si, sx, sy], [er, ei, ex, ey]) = (self.s0, self.e);
        let rx = sr * px - si * py + sx + weight * (er * px - ei * py + ex);
        let ry = si * px + sr * py + sy + weight * (ei * px + er * py + ey);
        [mirror(rx, tex.width as f32), mirror(ry, tex.height as f32)]
    }
}

impl FaceScene {
    /// Sets up `identity` for frames framed by `framing`; `eye_identity`
    /// gives the eyeballs (its iris colour is replaced by the photo's).
    pub fn new(
        identity: PhotoIdentity,
        mesh: &CanonicalMesh,
        mut eye_identity: Identity,
        framing: &Framing,
    ) -> FaceScene {
        let camera = Camera::from_vfov(framing.width, framing.height, framing.vfov_deg);
        let s = &identity.shape_cm;
        let dist = |a: [f32; 3], b: [f32; 3]| {
            (((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)) as f64).sqrt()
        };
        let face_cm = dist(s[lm::FOREHEAD], s[lm::CHIN]);
        // Framing: the frame shows a window of the photo around the face.
        // The face is at least `face_height_frac` of the frame, more where
        // the photo is too small around it (up to 0.6), so the frame stays
        // inside the photo; the window is centred a little below the face
        // (a webcam user sits with the face in the upper half) and slid
        // inside the photo, so a face off-centre in the photo is off-centre
        // in the frame too. Beyond the photo, the backdrop mirrors it.
        let (fw, fh) = (framing.width as f64, framing.height as f64);
        let (pw, ph) = (
            identity.texture.width as f64,
            identity.texture.height as f64,
        );
        let face_px = identity.face_height_px as f64;
        let face_height_frac = framing
            .face_height_frac
            .max(face_px / ph.min(pw * fh / fw))
            .min(0.6);
        let depth_cm = camera.focal_px * face_cm / (face_height_frac * fh);
        let lm_px = |i: usize| identity.landmarks_px[i].map(f64::from);
        let (a, b) = (lm_px(lm::FOREHEAD), lm_px(lm::CHIN));
        let mid_px = [(a[0] + b[0]) / 2.0, (a[1] + b[1]) / 2.0];
        let win_h = face_px / face_height_frac;
        let win_w = win_h * fw / fh;
        let slide = |c: f64, size: f64, extent: f64| {
            if size >= extent {
                extent / 2.0
            } else {
                c.clamp(size / 2.0, extent - size / 2.0)
            }
        };
        let win_cx = slide(mid_px[0], win_w, pw);
        let win_cy = slide(mid_px[1] + 0.06 * win_h, win_h, ph);
        // Where the face's middle lands in the frame.
        let out = [
            (mid_px[0] - win_cx) * fh / win_h + fw / 2.0,
            (mid_px[1] - win_cy) * fh / win_h + fh / 2.0,
        ];
        let mid = Vector3::new(
            (s[lm::FOREHEAD][0] + s[lm::CHIN][0]) as f64 / 2.0,
            (s[lm::FOREHEAD][1] + s[lm::CHIN][1]) as f64 / 2.0,
            (s[lm::FOREHEAD][2] + s[lm::CHIN][2]) as f64 / 2.0,
        );
        let mut rest_pose = HeadPose {
            yaw_deg: identity.photo_pose.yaw_deg,
            pitch_deg: identity.photo_pose.pitch_deg,
            roll_deg: identity.photo_pose.roll_deg,
            translation_cm: [0.0, 0.0, depth_cm],
        };
        let (m, _) = rest_pose.to_camera();
        let want = Vector3::new(
            (out[0] - camera.cx_px) / camera.focal_px * depth_cm,
            (out[1] - camera.cy_px) / camera.focal_px * depth_cm,
            depth_cm,
        );
        let t = want - m * mid;
        rest_pose.translation_cm = [t.x, t.y, t.z];

        // Eyes: the eyeball behind each lid contour, the photo's iris
        // colour and size.
        let eye_of = |contour: &[u32; 16], image_left_is_outer: bool| {
            let rig = LidRig::new(mesh, contour, image_left_is_outer);
            let n = contour.len() as f64;
            let mut c = Vector3::zeros();
            for &i in contour {
                c += Vector3::from(s[i as usize].map(f64::from)) / n;
            }
            c.z -= EYE_CENTRE_BEHIND_LIDS_CM;
            EyeSetup { rig, centre_cm: c }
        };
        let eyes = [
            eye_of(&RIGHT_EYE_CONTOUR, true),
            eye_of(&LEFT_EYE_CONTOUR, false),
        ];
        let lin = |c: u8| eyereplay_render::math::srgb_to_linear(c as f32);
        let iris = identity.iris_rgb.map(lin);
        eye_identity.iris.outer_rgb = iris;
        eye_identity.iris.inner_rgb = iris.map(|c| c * 0.8);
        // Its name, too: the identity file recorded the sampled palette
        // ("dark brown") beside the photo's green iris that was drawn.
        eye_identity.iris.palette = "the photo's".into();
        let photo_sclera = photo_sclera_linear(&identity);
        // The photo's iris radius relative to its eye width gives the
        // eyeball's iris radius in mm (the mesh is metric).
        let ratio: f64 = identity
            .eyes
            .iter()
            .zip(&eyes)
            .map(|(pe, es)| {
                let (a, b) = (
                    identity.landmarks_px[es.rig.corner_left as usize],
                    identity.landmarks_px[es.rig.corner_right as usize],
                );
                let w_px = ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt() as f64;
                let w_mm = 10.0
                    * dist(
                        s[es.rig.corner_left as usize],
                        s[es.rig.corner_right as usize],
                    );
                pe.iris_radius_px as f64 / w_px.max(1.0) * w_mm
            })
            .sum::<f64>()
            / 2.0;
        eye_identity.eye.iris_radius_mm = ratio.clamp(5.3, 6.5);
        let l = Vector3::from(framing.light_dir).normalize();
        // The eye model's own sclera and iris under this light, seen from
        // the front, against the photo's: a gain for the sclera, and the
        // iris texture scaled so that after that gain it shows the photo's
        // iris colour.
        let light_eye = [l.x as f32, -l.y as f32, l.z as f32];
        let probe = |ball: &Eyeball, x_mm: f32| -> [f32; 3] {
            ball.shade([x_mm, 0.0, 30.0], [0.0, 0.0, -1.0], light_eye, 1.0)
                .unwrap_or([0.5; 3])
        };
        let first = Eyeball::new(&eye_identity);
        let r_iris = first.iris_radius_mm() as f32;
        let sclera_ref = probe(&first, r_iris + 2.5);
        // One brightness gain, and a tint of at most 15 % per channel (a
        // small photo's "sclera" pixels also hold lid and lash).
        let luma = |c: [f32; 3]| 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
        let eye_gain: [f32; 3] = match photo_sclera {
            Some(ps) => {
                let g = (luma(ps) / luma(sclera_ref).max(1e-3)).clamp(0.3, 1.2);
                std::array::from_fn(|c| g * (ps[c] / sclera_ref[c].max(1e-3) / g).clamp(0.85, 1.15))
            }
            None => [1.0; 3],
        };
        let iris_ref = probe(&first, 0.75 * r_iris);
        for c in 0..3 {
            let want = iris[c];
            let got = (iris_ref[c] * eye_gain[c]).max(1e-4);
            let k = (want / got).clamp(0.3, 4.0);
            eye_identity.iris.outer_rgb[c] = (eye_identity.iris.outer_rgb[c] * k).min(1.0);
            eye_identity.iris.inner_rgb[c] = (eye_identity.iris.inner_rgb[c] * k).min(1.0);
        }
        let eyeball = Eyeball::new(&eye_identity);
        let (skirted, skirt_rings) = with_skirt(&identity, mesh);
        // The head's image motion is fitted to the skirt's outer edge (the
        // whole mesh, should it have no skirt).
        let skirt_edge = skirt_rings
            .last()
            .cloned()
            .unwrap_or_else(|| (0..skirted.positions_cm.len()).collect());
        let mut scene = FaceScene {
            mesh: skirted,
            eyes,
            lid_follow: (
                eye_identity.eye.upper_lid_follow,
                eye_identity.eye.lower_lid_follow,
            ),
            eye_identity,
            eyeball,
            eye_gain,
            face_frac: face_height_frac,
            camera,
            rest_pose,
            light_head: l,
            lut: SrgbLut::new(),
            backdrop: Backdrop {
                to_photo: Sim2::IDENTITY,
                still: vec![],
                weight: vec![],
                moving_box: [0; 4],
                anchors: vec![],
                rest_anchors_px: vec![],
            },
            identity,
        };
        scene.backdrop = scene.make_backdrop(skirt_edge);
        scene.skirt_onto_backdrop(&skirt_rings);
        scene
    }

    /// The skirt's texture coordinates, bent so that its outer edge samples
    /// the photo where the backdrop does at the rest pose. Each skirt ring
    /// was textured by projecting it with the photo's camera, but the frame
    /// is filmed with another (field of view, distance), so a receding ring
    /// lands elsewhere than the flat backdrop puts the same photo pixels:
    /// the photo's chin and neck showed twice, one above the other, and
    /// hair and the collar were cut along the skirt's edge, at the rest
    /// pose already. Now the outer ring takes the backdrop's photo point
    /// for its rest position (so skirt and backdrop meet without a seam
    /// while the head is at rest, and move apart only by what the head
    /// turns), ring `j` of `n` (innermost first) `(j + 1) / n` of the way
    /// there, and the face oval keeps its landmark.
    fn skirt_onto_backdrop(&mut self, rings: &[Vec<usize>]) {
        for (j, ring) in rings.iter().enumerate() {
            let t = ((j + 1) as f64 / rings.len() as f64) as f32;
            let rest = self.project(
                &self.rest_pose,
                ring.iter()
                    .map(|&v| Vector3::from(self.mesh.positions_cm[v].map(f64::from))),
            );
            for (&v, px) in ring.iter().zip(&rest) {
                let to = self.backdrop.to_photo.apply(*px);
                let uv = &mut self.mesh.uv_px[v];
                for c in 0..2 {
                    uv[c] += (to[c] as f32 - uv[c]) * t;
                }
            }
        }
    }

    pub fn width(&self) -> usize {
        self.camera.width_px
    }

    pub fn height(&self) -> usize {
        self.camera.height_px
    }

    /// Where the nose tip lands in the image under `head` (the frame's
    /// motion for the webcam's motion blur).
    pub fn nose_px(&self, head: &HeadPose) -> [f64; 2] {
        let p = Vector3::from(self.identity.shape_cm[lm::NOSE_TIP].map(f64::from));
        self.project(head, std::iter::once(p))[0]
    }

    /// Head-frame points -> image pixels under `pose`.
    fn project(&self, pose: &HeadPose, pts: impl Iterator<Item = Vector3<f64>>) -> Vec<[f64; 2]> {
        let (m, t) = pose.to_camera();
        pts.map(|p| self.camera.project(m * p + t)).collect()
    }

    /// The backdrop for this framing; `anchors` are the mesh vertices whose
    /// image motion it follows near the head (the skirt's outer edge, so
    /// the two meet where they join).
    fn make_backdrop(&self, anchors: Vec<usize>) -> Backdrop {
        let (w, h) = (self.width(), self.height());
        let s = &self.identity.shape_cm;
        let all = self.project(
            &self.rest_pose,
            s.iter().map(|p| Vector3::from(p.map(f64::from))),
        );
        let photo: Vec<[f64; 2]> = self
            .identity
            .landmarks_px
            .iter()
            .map(|p| p.map(f64::from))
            .collect();
        let to_photo = Sim2::fit(&all, &photo);
        let pos = &self.mesh.positions_cm;
        let rest_anchors_px = self.project(
            &self.rest_pose,
            anchors
                .iter()
                .map(|&i| Vector3::from(pos[i].map(f64::from))),
        );
        // The head's soft ellipse: from the forehead-chin line, wide and
        // tall enough for hair and neck.
        let (fh, ch) = (all[lm::FOREHEAD], all[lm::CHIN]);
        let face_px = ((fh[0] - ch[0]).powi(2) + (fh[1] - ch[1]).powi(2)).sqrt();
        let centre = [
            (fh[0] + ch[0]) / 2.0,
            (fh[1] + ch[1]) / 2.0 - 0.12 * face_px,
        ];
        let (ax, ay) = (0.62 * face_px, 0.85 * face_px);
        let mut weight = vec![0f32; w * h];
        let mut bx = [usize::MAX, usize::MAX, 0, 0];
        for y in 0..h {
            for x in 0..w {
                let dx = (x as f64 + 0.5 - centre[0]) / ax;
                let dy = (y as f64 + 0.5 - centre[1]) / ay;
                let rho = (dx * dx + dy * dy).sqrt();
                let t = ((1.4 - rho) / 0.4).clamp(0.0, 1.0);
                let wt = (t * t * (3.0 - 2.0 * t)) as f32;
                weight[y * w + x] = wt;
                if wt > 0.0 {
                    bx = [
                        bx[0].min(x),
                        bx[1].min(y),
                        bx[2].max(x + 1),
                        bx[3].max(y + 1),
                    ];
                }
            }
        }
        if bx[0] == usize::MAX {
            bx = [0; 4];
        }
        let mut still = vec![0u8; w * h * 3];
        let tex = &self.identity.texture;
        let still_warp = Warp::new(to_photo, Sim2::IDENTITY);
        still
            .par_chunks_mut(w * 3)
            .enumerate()
            .for_each(|(y, row)| {
                for x in 0..w {
                    let c = still_warp.sample_rgb8(tex, x as f32 + 0.5, y as f32 + 0.5, 0.0);
                    row[x * 3..x * 3 + 3].copy_from_slice(&c);
                }
            });
        Backdrop {
            to_photo,
            still,
            weight,
            moving_box: bx,
            anchors,
            rest_anchors_px,
        }
    }

    /// The mesh's vertex positions for one state: lids moved by the eyes'
    /// vertical rotation and the blink.
    fn posed_vertices(&self, state: &FaceState, out: &mut Vec<[f32; 3]>) {
        out.clear();
        out.extend_from_slice(&self.mesh.positions_cm);
        let base = &self.mesh.positions_cm;
        for (k, e) in self.eyes.iter().enumerate() {
            let (moved_up, moved_lo) = self.lid_margins(k, &state.eyes[k], state.closure);
            for j in 0..7 {
                out[e.rig.upper[j] as usize] = moved_up[j];
                out[e.rig.lower[j] as usize] = moved_lo[j];
            }
            for &(v, j, upper) in &e.rig.skin {
                let (lid, moved, f) = if upper {
                    (e.rig.upper[j], moved_up[j], UPPER_SKIN_FOLLOW)
                } else {
                    (e.rig.lower[j], moved_lo[j], LOWER_SKIN_FOLLOW)
                };
                let b = base[lid as usize];
                for c in 0..3 {
                    out[v as usize][c] = base[v as usize][c] + (moved[c] - b[c]) * f;
                }
            }
        }
    }

    /// Eye `k`'s upper and lower lid margin vertices (head frame, cm) for
    /// its rotation and the blink closure: both follow the eye's vertical
    /// rotation by the identity's follow factors, and closing moves the
    /// upper lid down onto the lower one.
    fn lid_margins(
        &self,
        k: usize,
        pose: &EyePose,
        closure: f64,
    ) -> ([[f32; 3]; 7], [[f32; 3]; 7]) {
        let e = &self.eyes[k];
        let base = &self.mesh.positions_cm;
        let (up_f, lo_f) = self.lid_follow;
        let lift = self.eyeball.limbus_z_mm() / 10.0 * pose.pitch_rad.sin();
        let eased = closure.clamp(0.0, 1.0);
        let c = (0.97 * eased) as f32;
        let mut up = [[0f32; 3]; 7];
        let mut lo = [[0f32; 3]; 7];
        for j in 0..7 {
            let mut pu = base[e.rig.upper[j] as usize];
            pu[1] += (up_f * lift) as f32;
            let mut pl = base[e.rig.lower[j] as usize];
            pl[1] += (lo_f * lift * (1.0 - 0.15 * eased)) as f32;
            for (u, l) in pu.iter_mut().zip(pl) {
                *u += (l - *u) * c;
            }
            up[j] = pu;
            lo[j] = pl;
        }
        (up, lo)
    }

    /// Where each eye's iris centre, corners and lids land in the image
    /// for `state` (image-left eye first).
    pub fn eye_images(&self, state: &FaceState) -> [EyeImage; 2] {
        [0, 1].map(|k| self.eye_image(state, k))
    }

    /// [`FaceScene::eye_images`] for eye `k` alone (the gaze solver's inner
    /// loop: only this eye's 17 points are posed and projected).
    pub fn eye_image(&self, state: &FaceState, k: usize) -> EyeImage {
        let op = self.opening(state, k);
        let g = Basis::gaze(state.eyes[k].yaw_rad, state.eyes[k].pitch_rad);
        let limbus_cm = self.eyeball.limbus_z_mm() / 10.0;
        // Render frame (y down) -> head frame (y up).
        let centre = self.eyes[k].centre_cm + Vector3::new(g.z.x, -g.z.y, g.z.z) * limbus_cm;
        let iris = self.project(&state.head, std::iter::once(centre))[0];
        let ix = iris[0];
        EyeImage {
            iris_px: iris,
            corner_left_px: op.corner_left,
            corner_right_px: op.corner_right,
            upper_px: [ix, op.lid_y_at(true, ix)],
            lower_px: [ix, op.lid_y_at(false, ix)],
        }
    }

    /// Eye `k`'s lid opening in the image for `state`.
    fn opening(&self, state: &FaceState, k: usize) -> Opening {
        let e = &self.eyes[k];
        let (up, lo) = self.lid_margins(k, &state.eyes[k], state.closure);
        let (m, t) = state.head.to_camera();
        let v = |p: [f32; 3]| self.camera.project(m * Vector3::from(p.map(f64::from)) + t);
        let base = &self.mesh.positions_cm;
        Opening {
            corner_left: v(base[e.rig.corner_left as usize]),
            corner_right: v(base[e.rig.corner_right as usize]),
            upper: up.map(v),
            lower: lo.map(v),
        }
    }

    /// Draws one frame into `frame` (resized if needed); `raster` and
    /// `verts` are reusable scratch for frames of this size.
    pub fn draw(
        &self,
        state: &FaceState,
        raster: &mut Rasterizer,
        mesh: &mut TexturedMesh,
        frame: &mut RgbImage,
    ) {
        self.draw_rows(state, raster, mesh, frame, 0..self.height());
    }

    /// [`FaceScene::draw`] whose output is needed in image rows `rows`
    /// only: there it is the same to the bit; elsewhere the frame holds
    /// whatever was cheapest (the face is drawn a feather's width beyond
    /// `rows`, for the outline's feathering inside them).
    pub fn draw_rows(
        &self,
        state: &FaceState,
        raster: &mut Rasterizer,
        mesh: &mut TexturedMesh,
        frame: &mut RgbImage,
        rows: std::ops::Range<usize>,
    ) {
        let (w, h) = (self.width(), self.height());
        if frame.width != w || frame.height != h {
            *frame = RgbImage::filled(w, h, [0, 0, 0]);
        }
        let rows = rows.start.min(h)..rows.end.min(h);
        // The face is drawn a feather's width beyond `rows`: the outline's
        // feathering inside them reads its coverage there.
        let r = self.feather_px();
        let covered = rows.start.saturating_sub(r)..(rows.end + r).min(h);
        // The still room first, the face over it; then the part of the
        // backdrop that follows the head, only where the face left the
        // pixel uncovered (most of the head box is face).
        let (a, b) = (covered.start * w * 3, covered.end * w * 3);
        frame.data[a..b].copy_from_slice(&self.backdrop.still[a..b]);
        if mesh.triangles.len() != self.mesh.triangles.len() {
            *mesh = self.mesh.clone();
        }
        self.posed_vertices(state, &mut mesh.positions_cm);
        raster.draw_rows(
            frame,
            &self.camera,
            &state.head,
            mesh,
            &self.identity.texture,
            covered,
        );
        let openings = [0, 1].map(|k| self.opening(state, k));
        let holes = openings.map(|op| self.pixel_box(&op.points().collect::<Vec<_>>(), 2.0));
        let face_box = self.screen_box(&state.head, &mesh.positions_cm);
        self.draw_backdrop(
            &state.head,
            raster.inv_depth(),
            &holes,
            face_box,
            rows.clone(),
            frame,
        );
        for k in 0..2 {
            let [x0, y0, x1, y1] = holes[k];
            let rect = [x0, y0.max(rows.start), x1, y1.min(rows.end)];
            self.draw_eye(state, k, &openings[k], rect, raster.inv_depth(), frame);
            // Over the eye: where the closing lid's triangles fold, the
            // eyeball showed through them.
            self.draw_closed_lid(state, k, &openings[k], frame);
        }
    }

    /// The rows of a frame drawn in state `b` that can differ from the same
    /// frame drawn in state `a` before the webcam look, where the two
    /// differ in their eyes only: the lid opening of each eye in each state,
    /// every face triangle with a vertex the eyes' lids moved, and what
    /// reads or feathers from them (the closing lid's skin band and ramp,
    /// the outline's feather), with a few pixels to spare. Empty where the
    /// two draw alike; `None` where they differ in more than the eyes (the
    /// head, the lids' closure, the pupil) or the lids moved the face's
    /// box (whose edges the whole outline's feather depends on).
    pub fn rows_changed_by_eyes(
        &self,
        a: &FaceState,
        b: &FaceState,
    ) -> Option<std::ops::Range<usize>> {
        if a.head != b.head || a.closure != b.closure || a.pupil_scale != b.pupil_scale {
            return None;
        }
        let same_eyes = a
            .eyes
            .iter()
            .zip(&b.eyes)
            .all(|(p, q)| p.yaw_rad == q.yaw_rad && p.pitch_rad == q.pitch_rad);
        if same_eyes {
            return Some(0..0);
        }
        let (mut va, mut vb) = (vec![], vec![]);
        self.posed_vertices(a, &mut va);
        self.posed_vertices(b, &mut vb);
        // The feather's box sums clamp at the face's box: a lid that moved
        // it (it never reaches the mesh's outline) would change the
        // feather along the whole outline.
        if self.screen_box(&a.head, &va) != self.screen_box(&b.head, &vb) {
            return None;
        }
        let moved: Vec<bool> = va.iter().zip(&vb).map(|(p, q)| p != q).collect();
        let mut pts: Vec<Vector3<f64>> = vec![];
        for tri in &self.mesh.triangles {
            if tri.iter().any(|&i| moved[i as usize]) {
                for &i in tri {
                    for v in [va[i as usize], vb[i as usize]] {
                        pts.push(Vector3::from(v.map(f64::from)));
                    }
                }
            }
        }
        let mut ys: Vec<f64> = self
            .project(&a.head, pts.into_iter())
            .iter()
            .map(|p| p[1])
            .collect();
        let mut eye_w: f64 = 0.0;
        for st in [a, b] {
            for k in 0..2 {
                // The opening as drawn, and with the lids open (the
                // closing lid's band is laid out from it).
                for closure in [st.closure, 0.0] {
                    let op = self.opening(&FaceState { closure, ..*st }, k);
                    eye_w = eye_w.max(op.width_px());
                    ys.extend(op.points().map(|p| p[1]));
                }
            }
        }
        let lo = ys.iter().copied().fold(f64::MAX, f64::min);
        let hi = ys.iter().copied().fold(f64::MIN, f64::max);
        if !(lo.is_finite() && hi.is_finite()) {
            return None;
        }
        // The closing lid reads skin up to 0.18 eye widths below the open
        // lower lid and fades in from a quarter of one above the upper; the
        // hole boxes reach 2 px past the lids; the feather spreads a change
        // by its radius.
        let margin = (0.5 * eye_w).ceil() + self.feather_px() as f64 + 4.0;
        let h = self.height() as f64;
        let start = (lo - margin).floor().clamp(0.0, h) as usize;
        let end = (hi + margin).ceil().clamp(0.0, h) as usize;
        Some(start..end.max(start))
    }

    /// The outline's feather radius (px): coverage is box-blurred over
    /// this many pixels each way ([`FaceScene::draw_backdrop`]).
    fn feather_px(&self) -> usize {
        ((0.03 * self.face_frac * self.height() as f64).round() as usize).max(1)
    }

    /// The pixel box of the mesh's vertices under `head`, one pixel wider
    /// each way, inside the frame.
    fn screen_box(&self, head: &HeadPose, verts: &[[f32; 3]]) -> [usize; 4] {
        let px = self.project(head, verts.iter().map(|p| Vector3::from(p.map(f64::from))));
        self.pixel_box(&px, 1.0)
    }

    /// `[x0, y0, x1, y1)` covering the points `px` plus `margin` pixels,
    /// inside the frame.
    fn pixel_box(&self, px: &[[f64; 2]], margin: f64) -> [usize; 4] {
        let (w, h) = (self.width() as f64, self.height() as f64);
        let lo = |i: usize| px.iter().map(|p| p[i]).fold(f64::MAX, f64::min);
        let hi = |i: usize| px.iter().map(|p| p[i]).fold(f64::MIN, f64::max);
        [
            (lo(0) - margin).clamp(0.0, w) as usize,
            (lo(1) - margin).clamp(0.0, h) as usize,
            (hi(0) + margin + 1.0).clamp(0.0, w) as usize,
            (hi(1) + margin + 1.0).clamp(0.0, h) as usize,
        ]
    }

    /// The part of the backdrop that follows the head, where the face left
    /// pixels uncovered; then the face's outline feathered into it over a
    /// few pixels (a hard outline shows as a seam once the head turns).
    /// `holes` are the eye openings, which are not outline.
    fn draw_backdrop(
        &self,
        head: &HeadPose,
        covered: &[f32],
        holes: &[[usize; 4]; 2],
        face_box: [usize; 4],
        rows: std::ops::Range<usize>,
        frame: &mut RgbImage,
    ) {
        let b = &self.backdrop;
        let w = self.width();
        let now = self.project(
            head,
            b.anchors
                .iter()
                .map(|&i| Vector3::from(self.mesh.positions_cm[i].map(f64::from))),
        );
        // Image motion of the head: current -> rest.
        let back = Sim2::fit(&now, &b.rest_anchors_px);
        let warp = Warp::new(b.to_photo, back);
        let [x0, y0, x1, y1] = b.moving_box;
        let (y0, y1) = (y0.max(rows.start), y1.min(rows.end).max(y0.max(rows.start)));
        let tex = &self.identity.texture;
        frame.data[y0 * w * 3..y1 * w * 3]
            .par_chunks_mut(w * 3)
            .enumerate()
            .for_each(|(dy, row)| {
                let y = y0 + dy;
                let py = y as f32 + 0.5;
                // Row slices, so the loop has no per-pixel bounds checks.
                let span = y * w + x0..y * w + x1;
                let pixels = b.weight[span.clone()]
                    .iter()
                    .zip(&covered[span])
                    .zip(row[x0 * 3..x1 * 3].chunks_exact_mut(3));
                for (x, ((&wt, &cover), px)) in (x0..).zip(pixels) {
                    if wt <= 0.0 || cover != 0.0 {
                        continue;
                    }
                    px.copy_from_slice(&warp.sample_rgb8(tex, x as f32 + 0.5, py, wt));
                }
            });
        // Feather: coverage (eye openings count as covered) box-blurred
        // over `r` px; a covered pixel whose neighbourhood is part
        // uncovered is mixed with the backdrop.
        let r = self.feather_px();
        // Only around the drawn mesh (its box), not the whole head region,
        // and in the rows wanted and the feather's reach around them (the
        // box sums inside `rows` read no further; their clamping at the
        // face box's edges is the same).
        let [x0, y0, x1, y1] = face_box;
        let (y0, y1) = (y0.max(rows.start.saturating_sub(r)), y1.min(rows.end + r));
        let (bw, bh) = (x1.saturating_sub(x0), y1.saturating_sub(y0));
        if bw == 0 || bh == 0 {
            return;
        }
        let in_hole = |x: usize, y: usize| {
            holes
                .iter()
                .any(|h| x >= h[0] && x < h[2] && y >= h[1] && y < h[3])
        };
        let mut m = vec![0u16; bw * bh];
        for y in 0..bh {
            for x in 0..bw {
                let (gx, gy) = (x0 + x, y0 + y);
                m[y * bw + x] = u16::from(covered[gy * w + gx] != 0.0 || in_hole(gx, gy));
            }
        }
        let blur = |src: &[u16], stride: usize, n: usize, count: usize, step: usize| {
            // Box sum along one axis (edges clamped).
            let mut out = vec![0u16; src.len()];
            for line in 0..count {
                let at = |i: usize| src[line * stride + i * step];
                let mut acc: u32 = 0;
                for i in 0..=r.min(n - 1) {
                    acc += at(i) as u32;
                }
                acc += at(0) as u32 * r as u32;
                for i in 0..n {
                    out[line * stride + i * step] = acc as u16;
                    let add = at((i + r + 1).min(n - 1)) as u32;
                    let sub = at(i.saturating_sub(r)) as u32;
                    acc = acc + add - sub;
                }
            }
            out
        };
        let hsum = blur(&m, bw, bw, bh, 1);
        let sum = blur(&hsum, 1, bh, bw, bw);
        let full = ((2 * r + 1) * (2 * r + 1)) as f32;
        for y in 0..bh {
            if !rows.contains(&(y0 + y)) {
                continue;
            }
            for x in 0..bw {
                let k = y * bw + x;
                if m[k] == 0 || sum[k] as f32 >= full {
                    continue;
                }
                let (gx, gy) = (x0 + x, y0 + y);
                if in_hole(gx, gy) {
                    continue;
                }
                let alpha = ((sum[k] as f32 / full - 0.5) * 2.0).clamp(0.0, 1.0);
                let wt = b.weight[gy * w + gx];
                let c = warp.sample(tex, gx as f32 + 0.5, gy as f32 + 0.5, wt);
                let o = (gy * w + gx) * 3;
                for (px, bg) in frame.data[o..o + 3].iter_mut().zip(c) {
                    *px = (bg + (*px as f32 - bg) * alpha + 0.5) as u8;
                }
            }
        }
    }

    /// Ray-traces eye `k` into the pixels of its lid opening (`op`, inside
    /// the pixel box `rect`) that the face left uncovered.
    /// The upper lid's skin where a blink has drawn it down. The lid's
    /// triangles, stretched over the eye, carried the photo's lashes and
    /// the band its iris was taken out of: a pale curtain with dark holes
    /// at full closure, streaks before it. The band between the open lid
    /// and the closing one is painted instead with the face's skin beside
    /// the eye, read in this frame just below the lower lid (past its
    /// lashes) and smoothed along it, darkening to a lash line at the
    /// closing margin; faded in over the first quarter of the closure.
    fn draw_closed_lid(&self, state: &FaceState, k: usize, now: &Opening, frame: &mut RgbImage) {
        let weight = ((state.closure - 0.02) / 0.23).clamp(0.0, 1.0) as f32;
        if weight <= 0.0 {
            return;
        }
        let open = self.opening(
            &FaceState {
                closure: 0.0,
                ..*state
            },
            k,
        );
        let (w, h) = (frame.width, frame.height);
        let eye_w = now.width_px();
        let xs = [now.corner_left[0], now.corner_right[0]];
        let x0 = xs[0].min(xs[1]).floor().max(0.0) as usize;
        let x1 = (xs[0].max(xs[1]).ceil().max(0.0) as usize).min(w);
        if x1 <= x0 + 1 || eye_w < 4.0 {
            return;
        }
        // Past the lashes, then a band of skin.
        let gap = (0.08 * eye_w).max(1.0);
        let band = (0.10 * eye_w).max(1.0);
        let lash = (0.05 * eye_w).max(1.0);
        let mean_of = |x: usize, ya: f64, yb: f64| -> [f32; 3] {
            let (ya, yb) = (ya.floor().max(0.0), yb.floor().max(0.0));
            let (ya, yb) = ((ya as usize).min(h - 1), (yb as usize).min(h - 1));
            let mut sum = [0f32; 3];
            for y in ya..=yb {
                let p = frame.pixel(x, y);
                for c in 0..3 {
                    sum[c] += p[c] as f32;
                }
            }
            sum.map(|v| v / (yb - ya + 1) as f32)
        };
        // Read below the lower lid, past its lashes: the skin above the
        // eye is the crease's shadow in deep-set eyes, and by now the
        // closing lid's triangles have pulled it down over the eye (grey
        // lids, dark smudges by the nose when it was read there).
        let skin: Vec<[f32; 3]> = (x0..x1)
            .map(|x| {
                let low = open.lid_y_at(false, x as f64 + 0.5) + gap;
                mean_of(x, low, low + band)
            })
            .collect();
        // Smoothed along the lid: the skin's shading stays, a stray
        // lash or crease does not.
        let reach = ((0.12 * eye_w) as usize).max(1);
        let smooth: Vec<[f32; 3]> = (0..skin.len())
            .map(|i| {
                let (a, b) = (i.saturating_sub(reach), (i + reach + 1).min(skin.len()));
                let mut sum = [0f32; 3];
                for s in &skin[a..b] {
                    for c in 0..3 {
                        sum[c] += s[c];
                    }
                }
                sum.map(|v| v / (b - a) as f32)
            })
            .collect();
        // Faded in over a quarter of the eye's width above the open lid's
        // line: the crease's texture the closing lid drags down is
        // covered, the brow is not.
        let ramp = (0.25 * eye_w).max(gap);
        for x in x0..x1 {
            let xc = x as f64 + 0.5;
            let upper = open.lid_y_at(true, xc);
            let margin = now.lid_y_at(true, xc);
            if margin <= upper - gap {
                continue;
            }
            let start = upper - ramp;
            let ya = start.floor().max(0.0) as usize;
            let yb = (margin.ceil().max(0.0) as usize).min(h);
            let col = smooth[x - x0];
            for y in ya..yb {
                let yc = y as f64 + 0.5;
                // In from `start` over `ramp`, out below the margin's
                // pixel; darker over the last `lash` px above the margin.
                let cover =
                    ((yc - start) / ramp).clamp(0.0, 1.0) * (margin - yc + 0.5).clamp(0.0, 1.0);
                let dark = 1.0 - 0.55 * (1.0 - ((margin - yc) / lash).clamp(0.0, 1.0));
                let a = weight * cover as f32;
                if a <= 0.0 {
                    continue;
                }
                let i = (y * w + x) * 3;
                for (px, skin) in frame.data[i..i + 3].iter_mut().zip(col) {
                    let want = skin * dark as f32;
                    let was = *px as f32;
                    *px = (was + a * (want - was)).round().clamp(0.0, 255.0) as u8;
                }
            }
        }
    }

    fn draw_eye(
        &self,
        state: &FaceState,
        k: usize,
        op: &Opening,
        rect: [usize; 4],
        inv_depth: &[f32],
        frame: &mut RgbImage,
    ) {
        let e = &self.eyes[k];
        let w = self.width();
        let (m, t) = state.head.to_camera();
        let mt = m.transpose();
        let [bx0, by0, bx1, by1] = rect;
        if bx1 <= bx0 || by1 <= by0 {
            return;
        }
        let eye_w = op.width_px();
        let shadow_px = (0.07 * eye_w).max(0.7);
        // Ray basis in the turned eye's frame (mm): the render crate's
        // head frame is this crate's with y flipped, in mm.
        let g = Basis::gaze(state.eyes[k].yaw_rad, state.eyes[k].pitch_rad);
        let to_eye = |d: Vector3<f64>| -> V3 { g.to_local(v3(d.x, -d.y, d.z)) };
        let f = self.camera.focal_px;
        let origin = to_eye((-(mt * t) - e.centre_cm) * 10.0);
        let dir_fwd = to_eye(mt * Vector3::new(0.0, 0.0, 1.0));
        let dir_right = to_eye(mt * Vector3::new(1.0 / f, 0.0, 0.0));
        let dir_down = to_eye(mt * Vector3::new(0.0, 1.0 / f, 0.0));
        let light = to_eye(self.light_head);
        let light = [light.x as f32, light.y as f32, light.z as f32];
        let skip = (origin.len() - 30.0) as f32;
        let (o, a, bx, by) = (origin.f(), dir_fwd.f(), dir_right.f(), dir_down.f());
        let (cx, cy) = (self.camera.cx_px as f32, self.camera.cy_px as f32);
        let pupil = state.pupil_scale as f32;
        let beside = f3(0.30, 0.16, 0.14);
        let corners = [op.corner_left, op.corner_right];
        // The upper lid's y per column of the box, for its shadow.
        let upper_y: Vec<f64> = (bx0..bx1)
            .map(|x| op.lid_y_at(true, x as f64 + 0.5))
            .collect();
        for y in by0..by1 {
            for x in bx0..bx1 {
                if inv_depth[y * w + x] != 0.0 {
                    continue;
                }
                let (pxf, pyf) = (x as f32 + 0.5, y as f32 + 0.5);
                let d = a + bx * (pxf - cx) + by * (pyf - cy);
                let d = d * (1.0 / d.dot(d).sqrt());
                let oo = o + d * skip;
                let c = self
                    .eyeball
                    .shade([oo.x, oo.y, oo.z], [d.x, d.y, d.z], light, pupil)
                    .map(|c| f3(c[0], c[1], c[2]))
                    .unwrap_or(beside);
                let du = (pyf as f64 - upper_y[x - bx0]).max(0.0);
                let dc = corners
                    .iter()
                    .map(|q| ((pxf as f64 - q[0]).powi(2) + (pyf as f64 - q[1]).powi(2)).sqrt())
                    .fold(f64::MAX, f64::min);
                let shade = (1.0 - 0.55 * (-du / shadow_px).exp())
                    * (1.0 - 0.35 * (-dc / (0.12 * eye_w).max(1.0)).exp());
                let g = self.eye_gain;
                let rgb = self
                    .lut
                    .rgb(f3(c.x * g[0], c.y * g[1], c.z * g[2]) * shade as f32);
                let i = (y * w + x) * 3;
                frame.data[i..i + 3].copy_from_slice(&rgb);
            }
        }
    }
}

/// The eye-in-head rotation that puts eye `k`'s iris at `target` `(nx, ny)`
/// in its aperture as the extractor measures it in the image, for a head
/// pose and lid closure (Newton's method on [`FaceScene::eye_images`],
/// started from the same guess every frame so frames are independent).
impl FaceScene {
    pub fn solve_eyes(&self, head: &HeadPose, target: (f64, f64), closure: f64) -> [EyePose; 2] {
        let limit = EYE_LIMIT_DEG.to_radians();
        let measure = |k: usize, pose: EyePose| -> (f64, f64) {
            let mut st = FaceState {
                head: *head,
                closure,
                pupil_scale: 1.0,
                ..Default::default()
            };
            st.eyes[k] = pose;
            let (nx, ny, _) = self.eye_image(&st, k).norm();
            (nx, ny)
        };
        std::array::from_fn(|k| {
            let (mut yaw, mut pitch) = (0.0f64, 0.0f64);
            let hstep = 1e-4;
            for _ in 0..8 {
                let p = EyePose {
                    yaw_rad: yaw,
                    pitch_rad: pitch,
                };
                let n0 = measure(k, p);
                let (ex, ey) = (n0.0 - target.0, n0.1 - target.1);
                if ex.abs() < 1e-6 && ey.abs() < 1e-6 {
                    break;
                }
                let na = measure(
                    k,
                    EyePose {
                        yaw_rad: yaw + hstep,
                        ..p
                    },
                );
                let nb = measure(
                    k,
                    EyePose {
                        pitch_rad: pitch + hstep,
                        ..p
                    },
                );
                let (j11, j21) = ((na.0 - n0.0) / hstep, (na.1 - n0.1) / hstep);
                let (j12, j22) = ((nb.0 - n0.0) / hstep, (nb.1 - n0.1) / hstep);
                let det = j11 * j22 - j12 * j21;
                if det.abs() < 1e-12 {
                    break;
                }
                yaw = (yaw - (j22 * ex - j12 * ey) / det).clamp(-limit, limit);
                pitch = (pitch - (-j21 * ex + j11 * ey) / det).clamp(-limit, limit);
            }
            EyePose {
                yaw_rad: yaw,
                pitch_rad: pitch,
            }
        })
    }
}

/// Rings of the skirt around the face oval: radial scale from the oval's
/// centre (head frame x, y) and depth behind the oval's vertex (cm).
const SKIRT_RINGS: [(f32, f32); 2] = [(1.2, 1.5), (1.5, 4.5)];

/// The photo-textured mesh with its eye openings left open, plus a skirt:
/// two rings of vertices around the face oval, outward and receding,
/// textured from the photo around the face (jaw, ears, hair, neck). The
/// canonical mesh ends at the face oval; without the skirt, what lies
/// around the face (the photo's own ears, hair and jaw line) stays flat in
/// the backdrop while the face turns, and the landmark model reads a
/// fraction of the turn (16 deg drawn, 4 deg read on Grace Hopper's photo).
///
/// Also returns the vertex ids of each skirt ring, innermost first (none,
/// should the mesh have no boundary); the last is the skirt's outer edge.
fn with_skirt(id: &PhotoIdentity, mesh: &CanonicalMesh) -> (TexturedMesh, Vec<Vec<usize>>) {
    let base = id.textured_mesh(mesh, true);
    let mut pos = base.positions_cm.clone();
    let mut uv = base.uv_px.clone();
    let mut tris = base.triangles.clone();
    let Some(oval) = mesh.boundary_loops().into_iter().max_by_key(|l| l.len()) else {
        return (base, vec![]);
    };
    let n = oval.len();
    let c = oval.iter().fold([0f32; 2], |a, &i| {
        let p = pos[i as usize];
        [a[0] + p[0] / n as f32, a[1] + p[1] / n as f32]
    });
    let (m, t) = id.photo_pose.to_camera();
    let front: f32 = tris
        .iter()
        .map(|tr| {
            let [a, b, c] = tr.map(|i| pos[i as usize]);
            (b[0] - a[0]) * (-c[1] + a[1]) - (-b[1] + a[1]) * (c[0] - a[0])
        })
        .sum::<f32>()
        .signum();
    let mut prev: Vec<u32> = oval.clone();
    let mut rings = vec![];
    for (scale, depth) in SKIRT_RINGS {
        let first = pos.len() as u32;
        for &i in &oval {
            let p = pos[i as usize];
            let q = [
                c[0] + (p[0] - c[0]) * scale,
                c[1] + (p[1] - c[1]) * scale,
                p[2] - depth,
            ];
            let cam = m * Vector3::new(q[0] as f64, q[1] as f64, q[2] as f64) + t;
            let px = id.photo_camera.project(cam);
            pos.push(q);
            uv.push([px[0] as f32, px[1] as f32]);
        }
        let ring: Vec<u32> = (0..n as u32).map(|k| first + k).collect();
        for k in 0..n {
            let (a, b) = (prev[k], prev[(k + 1) % n]);
            let (ra, rb) = (ring[k], ring[(k + 1) % n]);
            for mut tr in [[a, b, rb], [a, rb, ra]] {
                let [x, y, z] = tr.map(|i| pos[i as usize]);
                let area = (y[0] - x[0]) * (-z[1] + x[1]) - (-y[1] + x[1]) * (z[0] - x[0]);
                if area * front < 0.0 {
                    tr.swap(1, 2);
                }
                tris.push(tr);
            }
        }
        rings.push(ring.iter().map(|&i| i as usize).collect());
        prev = ring;
    }
    (TexturedMesh::new(pos, uv, tris), rings)
}

/// `v` reflected into `[0, n]` (mirror padding: a backdrop wider than the
/// photo repeats its edge region mirrored rather than smearing its edge
/// pixels into streaks).
#[inline(always)]
fn mirror(v: f32, n: f32) -> f32 {
    if (0.0..=n).contains(&v) {
        return v;
    }
    let p = 2.0 * n;
    let m = v.rem_euclid(p);
    if m > n {
        p - m
    } else {
        m
    }
}

/// Mean linear colour of the photo's visible sclera: inside each eye's lid
/// contour, more than 1.3 iris radii from the iris centre, the brightest
/// half (lashes and lid shadow excluded); `None` when too few pixels show.
fn photo_sclera_linear(id: &PhotoIdentity) -> Option<[f32; 3]> {
    let mut px: Vec<[u8; 3]> = vec![];
    for e in &id.eyes {
        let poly = e.contour_px(&id.landmarks_px);
        let (mut x0, mut y0, mut x1, mut y1) = (f32::MAX, f32::MAX, f32::MIN, f32::MIN);
        for p in &poly {
            x0 = x0.min(p[0]);
            y0 = y0.min(p[1]);
            x1 = x1.max(p[0]);
            y1 = y1.max(p[1]);
        }
        let t = &id.texture;
        for y in (y0.max(0.0) as usize)..(y1.ceil() as usize).min(t.height) {
            for x in (x0.max(0.0) as usize)..(x1.ceil() as usize).min(t.width) {
                let p = [x as f32 + 0.5, y as f32 + 0.5];
                let d = ((p[0] - e.iris_center_px[0]).powi(2)
                    + (p[1] - e.iris_center_px[1]).powi(2))
                .sqrt();
                if d > 1.3 * e.iris_radius_px && crate::photo::inside(&poly, p) {
                    px.push(t.pixel(x, y));
                }
            }
        }
    }
    if px.len() < 8 {
        return None;
    }
    px.sort_by_key(|c| 299 * c[0] as u32 + 587 * c[1] as u32 + 114 * c[2] as u32);
    let kept = &px[px.len() / 2..];
    let lin = |c: u8| eyereplay_render::math::srgb_to_linear(c as f32);
    let mut sum = [0f32; 3];
    for c in kept {
        for k in 0..3 {
            sum[k] += lin(c[k]);
        }
    }
    Some(sum.map(|v| v / kept.len() as f32))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The least-squares similarity recovers a known one exactly: scale 2,
    /// rotation 30 deg, shift (5, -3).
    #[test]
    fn similarity_fit_recovers_a_known_map() {
        let (c, s) = (
            2.0 * 30f64.to_radians().cos(),
            2.0 * 30f64.to_radians().sin(),
        );
        let truth = Sim2 {
            ar: c,
            ai: s,
            bx: 5.0,
            by: -3.0,
        };
        let from = [[0.0, 0.0], [10.0, 0.0], [0.0, 7.0], [4.0, 9.0]];
        let to: Vec<[f64; 2]> = from.iter().map(|p| truth.apply(*p)).collect();
        let got = Sim2::fit(&from, &to);
        for (a, b) in [(got.ar, c), (got.ai, s), (got.bx, 5.0), (got.by, -3.0)] {
            assert!((a - b).abs() < 1e-12, "{got:?}");
        }
    }

    /// With the head at rest the warp is the rest map whatever the weight;
    /// with the head moved, weight 1 samples where the rest map sends the
    /// pixel the head came from (1x1 photo texels as coordinates).
    #[test]
    fn warp_follows_the_head_by_its_weight() {
        // A 64x64 texture whose red channel is x and green channel y.
        let mut tex = RgbImage::filled(64, 64, [0, 0, 0]);
        for y in 0..64 {
            for x in 0..64 {
                let i = (y * 64 + x) * 3;
                tex.data[i] = x as u8;
                tex.data[i + 1] = y as u8;
            }
        }
        // Output -> photo: shift by (10, 20).
        let s0 = Sim2 {
            ar: 1.0,
            ai: 0.0,
            bx: 10.0,
            by: 20.0,
        };
        let still = Warp::new(s0, Sim2::IDENTITY);
        for wt in [0.0, 0.5, 1.0] {
            let c = still.sample(&tex, 3.5, 4.5, wt);
            assert!(
                (c[0] - 13.0).abs() < 1e-4 && (c[1] - 24.0).abs() < 1e-4,
                "{c:?}"
            );
        }
        // The head moved 6 px right: back(p) = p - (6, 0).
        let back = Sim2 {
            bx: -6.0,
            ..Sim2::IDENTITY
        };
        let moving = Warp::new(s0, back);
        let c = moving.sample(&tex, 9.5, 4.5, 1.0);
        assert!((c[0] - 13.0).abs() < 1e-4, "{c:?}");
        let c = moving.sample(&tex, 9.5, 4.5, 0.5);
        assert!((c[0] - 16.0).abs() < 1e-4, "{c:?}");
    }

    /// Mirror padding reflects about both edges and leaves inside points.
    #[test]
    fn mirror_reflects_at_the_edges() {
        assert_eq!(mirror(3.0, 10.0), 3.0);
        assert_eq!(mirror(-2.0, 10.0), 2.0);
        assert_eq!(mirror(12.0, 10.0), 8.0);
        assert_eq!(mirror(23.0, 10.0), 3.0);
    }

    /// A lid polyline read at x: linear between its points, the end
    /// points' y beyond the corners.
    #[test]
    fn lid_polyline_interpolates() {
        let upper: [[f64; 2]; 7] = std::array::from_fn(|k| [10.0 + 10.0 * k as f64, 40.0]);
        let op = Opening {
            corner_left: [0.0, 50.0],
            corner_right: [80.0, 50.0],
            upper,
            lower: upper.map(|p| [p[0], 60.0]),
        };
        assert!((op.lid_y_at(true, 5.0) - 45.0).abs() < 1e-12);
        assert!((op.lid_y_at(true, 35.0) - 40.0).abs() < 1e-12);
        assert!((op.lid_y_at(false, 75.0) - 55.0).abs() < 1e-12);
        assert_eq!(op.lid_y_at(true, -3.0), 50.0);
        assert_eq!(op.lid_y_at(true, 90.0), 50.0);
        assert!((op.width_px() - 80.0).abs() < 1e-12);
    }
}
