//! The eye simulator's scene: everything static for one identity and image
//! size ([`Scene`]), its camera, and where each eye lands in the image. The
//! stages that build on it (gaze solving, textures, hair, the face
//! background, per-frame rendering, per-pixel shading) are submodules, one
//! job each, listed below.
//!
//! # Geometry (documented for eye-crop location)
//!
//! Head frame, millimetres: x toward image right, y down, z toward the
//! camera; the origin is midway between the two eyeball centres, which sit
//! at `x = -ipd/2` (the image-left eye) and `x = +ipd/2` (image-right eye).
//! A pinhole camera at `distance_mm` looks at a point a few millimetres above
//! the eyes (so the eyes sit at 55 % of the image height, the brows above),
//! covering `field_width_mm` across the image at the eyes' depth, orbited by
//! the identity's small yaw/pitch/roll. [`Scene::geometry`] reports where
//! each eye's corners and bounding box land in the image.
//!
//! Each eye is a sclera sphere (`eyeball_radius_mm`) with a corneal cap
//! (radius 7.8 mm, refractive index 1.376) that meets the sclera at the
//! limbus (`iris_radius_mm`), a flat iris 0.6 mm behind the limbus plane seen
//! through the refracting cornea, and a pupil whose radius drifts slowly.
//! The lids are curves on the eyeball surface between fixed corners; the
//! upper lid follows the iris's vertical motion by `upper_lid_follow`, the
//! lower by `lower_lid_follow`, and both close during blinks.

//!
//! # Where each stage lives
//!
//! - [`eye_model`]: the eye and its lids in millimetres (head frame).
//! - this module: the scene's set-up, camera, and where each eye's box lands
//!   in the image.
//! - [`pose`]: gaze solving and ground truth measured in the image.
//! - [`textures`]: iris and sclera textures.
//! - [`hair`]: lash textures and brows, drawn as strands.
//! - [`background`]: the static face, drawn once per session.
//! - [`frame`]: per-frame set-up of each eye box and writing it into
//!   yuv420p or RGB.
//! - [`shade`]: per-pixel shading (the hot path).
//!
//! Colour conversion to yuv420p is the encoder's (`crate::encode`).

mod background;
mod eye_model;
mod eyeball;
mod frame;
mod hair;
mod pose;
mod shade;
mod textures;

use self::eye_model::EyeModel;
pub use self::eyeball::Eyeball;
use self::pose::PITCH_LIMIT_RAD;
use self::shade::BallPx;
use self::textures::Textures;
use crate::encode::rgb_to_yuv420;
use crate::identity::{CameraPose, Identity};
use crate::math::{f3, v3, Basis, SrgbLut, F3, V3};
use eyereplay_core::NormPos;
use serde::{Deserialize, Serialize};

/// Which eye, by its side in the image (the image-left eye is the subject's
/// right eye); the dataset format's type, so identity files and the
/// renderer agree.
pub use eyereplay_dataset::Side;

/// Pinhole camera; pixel centres are at integer + 0.5.
#[derive(Clone, Copy, Debug)]
pub struct Camera {
    pub pos: V3,
    pub right: V3,
    pub down: V3,
    pub fwd: V3,
    pub f_px: f64,
    pub cx: f64,
    pub cy: f64,
}

impl Camera {
    /// The camera of an identity's pose for a `width` x `height` image:
    /// `field_width_mm` across the image at the eyes' depth, aimed a little
    /// above the eyes, orbited by the pose's yaw, pitch and roll.
    fn new(cam_p: &CameraPose, width: usize, height: usize) -> Camera {
        let f_px = width as f64 * cam_p.distance_mm / cam_p.field_width_mm;
        // Aim a little above the eyes so they land at 55 % of the height.
        let look = v3(0.0, -0.05 * height as f64 * cam_p.distance_mm / f_px, 0.0);
        let base = Basis::IDENTITY.rotated(
            cam_p.yaw_deg.to_radians(),
            cam_p.pitch_deg.to_radians(),
            cam_p.roll_deg.to_radians(),
        );
        Camera {
            pos: look + base.z * cam_p.distance_mm,
            right: base.x,
            down: base.y,
            fwd: -base.z,
            f_px,
            cx: width as f64 / 2.0,
            cy: height as f64 / 2.0,
        }
    }

    /// Image position (px) of head-frame point `p`.
    pub fn project(&self, p: V3) -> [f64; 2] {
        let d = p - self.pos;
        let z = d.dot(self.fwd);
        [
            self.cx + self.f_px * d.dot(self.right) / z,
            self.cy + self.f_px * d.dot(self.down) / z,
        ]
    }
}

/// Where things are in the image for one eye: written to each session's
/// identity file, so the type is the dataset format's.
pub use eyereplay_dataset::EyeGeometry;

/// One frame's pose of both eyes, as solved from the trajectory.
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize)]
pub struct EyePose {
    pub yaw_rad: f64,
    pub pitch_rad: f64,
}

/// Measured (ground-truth) state of one eye in one rendered frame.
#[derive(Clone, Copy, Debug, Default)]
pub struct EyeTruth {
    pub pose: EyePose,
    pub iris_px: [f64; 2],
    /// Iris position normalized in the aperture as in the paper's eq. 1.
    pub norm: NormPos,
    /// Lid gap at the lid midpoint divided by the corner-to-corner width.
    pub aperture: f64,
}

/// Per-eye precomputed image-space data.
struct EyeRaster {
    model: EyeModel,
    x0: usize,
    y0: usize,
    w: usize,
    h: usize,
    /// Face background in the box, linear RGB (lids are drawn from it).
    bg_lin: Vec<F3>,
    /// Upper lashes: alpha by (row above margin + LASH_ROOT_PX, column).
    lash_up: Vec<f32>,
    lash_up_rows: usize,
    lash_lo: Vec<f32>,
    lash_lo_rows: usize,
    /// Per column: how far above the upper margin and below the lower one
    /// anything (lashes, lash line, waterline) is drawn, in px.
    up_reach: Vec<f32>,
    lo_reach: Vec<f32>,
    inner_corner_px: [f64; 2],
    outer_corner_px: [f64; 2],
    /// The eyeball as seen through each pixel of the box, row-major.
    ball: Vec<BallPx>,
}

/// Everything static for one identity and image size.
pub struct Scene {
    pub identity: Identity,
    pub width: usize,
    pub height: usize,
    pub camera: Camera,
    eyes: [EyeRaster; 2],
    tex: Textures,
    lut: SrgbLut,
    /// Key light direction (toward the light), head frame.
    light: V3,
    light_rgb: F3,
    ambient: f32,
    px_per_mm: f64,
    /// Static background, sRGB bytes, and its yuv420p planes.
    bg_rgb: Vec<u8>,
    bg_yuv: Vec<u8>,
}

impl Scene {
    /// Sets up everything static for one identity and image size: camera,
    /// eye models and boxes, textures, the face background (linear, sRGB
    /// and yuv420p), lash textures and the per-pixel sclera data.
    pub fn new(identity: &Identity, width: usize, height: usize) -> Scene {
        let id = identity.clone();
        let camera = Camera::new(&id.camera, width, height);
        let px_per_mm = camera.f_px / id.camera.distance_mm;
        let el = (id.lighting.key_elevation_deg).to_radians();
        let az = (id.lighting.key_azimuth_deg).to_radians();
        let light = v3(el.cos() * az.sin(), -el.sin(), el.cos() * az.cos()).norm();
        let t = id.lighting.tint_rgb;
        let light_rgb = f3(t[0], t[1], t[2]) * id.lighting.key_intensity;
        let mut scene = Scene {
            width,
            height,
            camera,
            eyes: Side::BOTH.map(|side| EyeRaster::empty(EyeModel::new(&id.eye, side))),
            tex: Textures::new(&id),
            lut: SrgbLut::new(),
            light,
            light_rgb,
            ambient: id.lighting.ambient,
            px_per_mm,
            bg_rgb: Vec::new(),
            bg_yuv: Vec::new(),
            identity: id,
        };
        for side in Side::BOTH {
            scene.place_box(side);
        }
        let bg_lin = scene.background();
        scene.bg_rgb = bg_lin.iter().flat_map(|c| scene.lut.rgb(*c)).collect();
        scene.bg_yuv = vec![0; width * height * 3 / 2];
        rgb_to_yuv420(
            &scene.bg_rgb,
            width,
            [0, 0, width, height],
            &mut scene.bg_yuv,
            width,
            height,
        );
        for side in Side::BOTH {
            let e = scene.eye(side);
            let (x0, y0, w, h) = (e.x0, e.y0, e.w, e.h);
            let mut b = Vec::with_capacity(w * h);
            for y in y0..y0 + h {
                b.extend_from_slice(&bg_lin[y * width + x0..y * width + x0 + w]);
            }
            scene.eye_mut(side).bg_lin = b;
            scene.make_lashes(side);
            scene.make_ball(side);
        }
        scene
    }

    /// The eye on `side` with its per-session image-space data.
    fn eye(&self, side: Side) -> &EyeRaster {
        &self.eyes[side.index()]
    }

    fn eye_mut(&mut self, side: Side) -> &mut EyeRaster {
        &mut self.eyes[side.index()]
    }

    /// Pixels per millimetre at the eyes' depth.
    pub fn px_per_mm(&self) -> f64 {
        self.px_per_mm
    }

    /// Where each eye is in the image.
    pub fn geometry(&self) -> [EyeGeometry; 2] {
        Side::BOTH.map(|side| {
            let e = self.eye(side);
            EyeGeometry {
                side: e.model.side,
                inner_corner_px: e.inner_corner_px,
                outer_corner_px: e.outer_corner_px,
                centre_px: self.camera.project(e.model.centre),
                box_px: [
                    e.x0 as u32,
                    e.y0 as u32,
                    (e.x0 + e.w) as u32,
                    (e.y0 + e.h) as u32,
                ],
                px_per_mm: self.px_per_mm,
            }
        })
    }

    /// The static background as yuv420p planes (what frames start from).
    pub fn background_yuv(&self) -> &[u8] {
        &self.bg_yuv
    }

    /// The static background, sRGB bytes.
    pub fn background_rgb(&self) -> &[u8] {
        &self.bg_rgb
    }

    /// Places the box of the eye on `side`: around its open lid curves at
    /// the solver's lowest, middle and highest pitch, plus room for the
    /// lashes and a margin, on even pixels (whole 2x2 chroma blocks) within
    /// its half of the image; and records its corners in the image.
    fn place_box(&mut self, side: Side) {
        let sh = self.identity.eye.clone();
        let m = self.eye(side).model.clone();
        let mut xs = Vec::new();
        let mut ys = Vec::new();
        for pitch in [-PITCH_LIMIT_RAD, 0.0, PITCH_LIMIT_RAD] {
            let lids = m.lids(&sh, pitch, 0.0);
            for i in 0..=32 {
                let s = i as f64 / 32.0;
                for upper in [true, false] {
                    let p = self.camera.project(m.lid_point(s, &lids, upper));
                    xs.push(p[0]);
                    ys.push(p[1]);
                }
            }
        }
        let lash = self.lash_up_px();
        let margin = 6.0;
        let xmin = xs.iter().cloned().fold(f64::MAX, f64::min) - 0.35 * lash - margin;
        let xmax = xs.iter().cloned().fold(f64::MIN, f64::max) + 0.35 * lash + margin;
        let ymin = ys.iter().cloned().fold(f64::MAX, f64::min) - lash - margin;
        let ymax = ys.iter().cloned().fold(f64::MIN, f64::max) + 0.45 * lash + margin;
        let mid = self.width / 2;
        let (lo_x, hi_x) = if m.side == Side::Left {
            (0, mid)
        } else {
            (mid, self.width)
        };
        let even_down =
            |v: f64, lo: usize, hi: usize| ((v.max(lo as f64) as usize) & !1).clamp(lo, hi);
        let even_up =
            |v: f64, lo: usize, hi: usize| (((v.ceil().max(0.0) as usize) + 1) & !1).clamp(lo, hi);
        let x0 = even_down(xmin, lo_x, hi_x);
        let x1 = even_up(xmax, lo_x, hi_x);
        let y0 = even_down(ymin, 0, self.height);
        let y1 = even_up(ymax, 0, self.height);
        let open = m.lids(&sh, 0.0, 0.0);
        let inner_corner_px = self.camera.project(m.lid_point(0.0, &open, true));
        let outer_corner_px = self.camera.project(m.lid_point(1.0, &open, true));
        let e = self.eye_mut(side);
        e.x0 = x0;
        e.y0 = y0;
        e.w = x1.saturating_sub(x0);
        e.h = y1.saturating_sub(y0);
        e.inner_corner_px = inner_corner_px;
        e.outer_corner_px = outer_corner_px;
    }
}

impl EyeRaster {
    fn empty(model: EyeModel) -> EyeRaster {
        EyeRaster {
            model,
            x0: 0,
            y0: 0,
            w: 0,
            h: 0,
            bg_lin: Vec::new(),
            lash_up: Vec::new(),
            lash_up_rows: 0,
            lash_lo: Vec::new(),
            lash_lo_rows: 0,
            up_reach: Vec::new(),
            lo_reach: Vec::new(),
            inner_corner_px: [0.0; 2],
            outer_corner_px: [0.0; 2],
            ball: Vec::new(),
        }
    }
}
