//! The eye simulator: geometry, camera, lids, textures, and per-frame
//! rendering of the two eye regions over a cached face background.
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

use crate::identity::Identity;
use crate::math::{clamp01, f3, floor_fast, smoothstep, v3, Basis, SrgbLut, F3, V3};
use crate::rng::{Noise2, SplitMix64};
use eyereplay_core::NormPos;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

const CORNEA_RADIUS_MM: f64 = 7.8;
const CORNEA_INDEX: f64 = 1.376;
const IRIS_BEHIND_LIMBUS_MM: f64 = 0.6;
const YAW_LIMIT_RAD: f64 = 0.8; // about 46 degrees
const PITCH_LIMIT_RAD: f64 = 0.6; // about 34 degrees
const IRIS_TEX: usize = 256;
const SCLERA_TEX: usize = 128;
/// Lash texture rows below the lid margin (lash roots overlap the eye).
const LASH_ROOT_PX: usize = 3;

/// Which eye, by its side in the image; the on-disk type of the dataset
/// format, so identity files and the renderer agree.
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
    pub fn project(&self, p: V3) -> [f64; 2] {
        let d = p - self.pos;
        let z = d.dot(self.fwd);
        [
            self.cx + self.f_px * d.dot(self.right) / z,
            self.cy + self.f_px * d.dot(self.down) / z,
        ]
    }
}

/// Static geometry of one eye in the head frame.
#[derive(Clone, Debug)]
struct EyeModel {
    side: Side,
    centre: V3,
    radius_mm: f64,
    iris_radius_mm: f64,
    /// z of the limbus plane in eye coordinates.
    limbus_z_mm: f64,
    cornea_centre_z_mm: f64,
    iris_z_mm: f64,
    /// x offset of the inner and outer corner from the eye centre.
    inner_x_mm: f64,
    outer_x_mm: f64,
    inner_y_mm: f64,
    outer_y_mm: f64,
    upper_exp: f64,
    lower_exp: f64,
}

/// Lid state of one eye for one frame, in millimetres.
#[derive(Clone, Copy, Debug)]
struct LidState {
    upper_mm: f64,
    lower_mm: f64,
    closure: f64,
}

impl EyeModel {
    /// Point on a lid margin at `s` (0 inner corner, 1 outer), head frame.
    fn lid_point(&self, s: f64, lids: &LidState, upper: bool) -> V3 {
        let x = self.inner_x_mm + s * (self.outer_x_mm - self.inner_x_mm);
        let base = self.inner_y_mm + s * (self.outer_y_mm - self.inner_y_mm);
        let lower_y = base
            + lids.lower_mm
                * (std::f64::consts::PI * s.powf(self.lower_exp))
                    .sin()
                    .max(0.0)
                    .powf(0.8);
        let y = if upper {
            let open = base
                - lids.upper_mm
                    * (std::f64::consts::PI * s.powf(self.upper_exp))
                        .sin()
                        .max(0.0)
                        .powf(0.55);
            // Closing moves the upper lid down onto the lower one.
            open + (lower_y - 0.02 - open) * lids.closure
        } else {
            lower_y
        };
        // The lids lie on the eyeball (plus their thickness); past the
        // sphere (towards the corners) they recede to the canthus.
        let r2 = self.radius_mm * self.radius_mm - x * x - y * y;
        let z = r2.max(9.0).sqrt() + 0.5;
        self.centre + v3(x, y, z)
    }

    fn lids(&self, shape: &crate::identity::EyeShape, pitch: f64, closure: f64) -> LidState {
        // Vertical iris displacement (mm, up positive) that the lids follow.
        let lift = self.limbus_z_mm * pitch.sin();
        let eased = closure * closure * (3.0 - 2.0 * closure);
        LidState {
            upper_mm: (shape.upper_lid_mm + shape.upper_lid_follow * lift).max(0.3),
            lower_mm: ((shape.lower_lid_mm - shape.lower_lid_follow * lift) * (1.0 - 0.15 * eased))
                .max(0.8),
            closure: eased,
        }
    }

    fn iris_centre(&self, rot: &Basis) -> V3 {
        self.centre + rot.z * self.limbus_z_mm
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

struct Textures {
    /// Iris colour over [-r, r]^2 of the iris plane, linear RGB.
    iris: Vec<F3>,
    /// Sclera colour over the eye's front hemisphere (x/R, y/R in [-1, 1]).
    sclera: Vec<F3>,
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

/// What does not change when the eye turns, for one pixel's ray.
///
/// The eyeball turns about its own centre, so the point where a pixel's
/// ray meets the sclera sphere, its normal, and the lighting there (key
/// light and camera are fixed in the head frame) are the same in every
/// frame; only which sclera texel lies at that point changes. Computing
/// them once per session leaves a rotation of `n` and a texture fetch per
/// sclera pixel, where the ray tracer spent most of a frame before.
#[derive(Clone, Copy, Debug, Default)]
struct BallPx {
    /// Head frame, unit: the sclera normal where the ray hits the ball, or,
    /// where it passes beside it (toward the corners), the direction of
    /// the ray's closest approach to the centre.
    n: F3,
    /// Colour = sclera texel * `mul` + `add` (linear RGB).
    mul: F3,
    add: F3,
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

/// Eye dimensions in f32 for the per-pixel ray tracer (eye coordinates, mm).
struct EyeGeoF32 {
    radius: f32,
    iris_r: f32,
    limbus_z: f32,
    cornea_z: f32,
    cornea_r: f32,
    iris_z: f32,
}

/// Per-frame, per-eye values shared by all pixels.
struct EyeFrame<'a> {
    r: &'a EyeRaster,

    origin: F3,
    dir_fwd: F3,
    dir_right: F3,
    dir_down: F3,
    light: F3,
    cx: f32,
    cy: f32,
    geo: EyeGeoF32,
    pupil_mm: f32,
    up: Vec<f32>,
    lo: Vec<f32>,
    /// Per column: corner shading factor and caruncle blend, from the lid
    /// parameter s (0 inner corner .. 1 outer).
    corner_col: Vec<(f32, f32)>,
    /// How far along a ray to jump before intersecting (keeps precision).
    origin_skip_mm: f32,
    /// The eye's x and y axes in the head frame: a head-frame normal's
    /// sclera texture coordinates are its dot products with them.
    axis_x: F3,
    axis_y: F3,
    /// Head-frame ray of a pixel (unnormalized): `ray_fwd + ray_right * (px
    /// - cx) + ray_down * (py - cy)`.
    ray_fwd: F3,
    ray_right: F3,
    ray_down: F3,
    /// From the camera to the centre of the sphere that bounds the corneal
    /// cap (limbus plane centre), head frame, and `|q|^2 - r_bound^2`: rays
    /// farther than `r_bound` from that centre cannot meet the cornea.
    cap_q: F3,
    cap_qq_minus_r2: f32,
    waterline_px: f32,
    inv_shadow_px: f32,
    hair: F3,
    wet: F3,
    caruncle: F3,
}

impl Scene {
    pub fn new(identity: &Identity, width: usize, height: usize) -> Scene {
        let id = identity.clone();
        let cam_p = &id.camera;
        let f_px = width as f64 * cam_p.distance_mm / cam_p.field_width_mm;
        // Aim a little above the eyes so they land at 55 % of the height.
        let look = v3(0.0, -0.05 * height as f64 * cam_p.distance_mm / f_px, 0.0);
        let base = Basis::IDENTITY.rotated(
            cam_p.yaw_deg.to_radians(),
            cam_p.pitch_deg.to_radians(),
            cam_p.roll_deg.to_radians(),
        );
        let camera = Camera {
            pos: look + base.z * cam_p.distance_mm,
            right: base.x,
            down: base.y,
            fwd: -base.z,
            f_px,
            cx: width as f64 / 2.0,
            cy: height as f64 / 2.0,
        };
        let px_per_mm = f_px / cam_p.distance_mm;
        let sh = &id.eye;
        let limbus_z = (sh.eyeball_radius_mm.powi(2) - sh.iris_radius_mm.powi(2)).sqrt();
        let cornea_z = limbus_z - (CORNEA_RADIUS_MM.powi(2) - sh.iris_radius_mm.powi(2)).sqrt();
        let tilt = sh.canthal_tilt_deg.to_radians().tan();
        let up_exp = 0.5f64.ln() / sh.upper_peak_frac.ln();
        let lo_exp = 0.5f64.ln() / 0.56f64.ln();
        let model = |side: Side| {
            let sign = if side == Side::Left { 1.0 } else { -1.0 };
            let half = sh.fissure_width_mm / 2.0;
            EyeModel {
                side,
                centre: v3(-sign * sh.ipd_mm / 2.0, 0.0, 0.0),
                radius_mm: sh.eyeball_radius_mm,
                iris_radius_mm: sh.iris_radius_mm,
                limbus_z_mm: limbus_z,
                cornea_centre_z_mm: cornea_z,
                iris_z_mm: limbus_z - IRIS_BEHIND_LIMBUS_MM,
                inner_x_mm: sign * half,
                outer_x_mm: -sign * half,
                inner_y_mm: 0.7,
                outer_y_mm: 0.7 - sh.fissure_width_mm * tilt,
                upper_exp: up_exp,
                lower_exp: lo_exp,
            }
        };
        let el = (id.lighting.key_elevation_deg).to_radians();
        let az = (id.lighting.key_azimuth_deg).to_radians();
        let light = v3(el.cos() * az.sin(), -el.sin(), el.cos() * az.cos()).norm();
        let t = id.lighting.tint_rgb;
        let light_rgb = f3(t[0], t[1], t[2]) * id.lighting.key_intensity;
        let mut scene = Scene {
            width,
            height,
            camera,
            eyes: [
                EyeRaster::empty(model(Side::Left)),
                EyeRaster::empty(model(Side::Right)),
            ],
            tex: Textures {
                iris: Vec::new(),
                sclera: Vec::new(),
            },
            lut: SrgbLut::new(),
            light,
            light_rgb,
            ambient: id.lighting.ambient,
            px_per_mm,
            bg_rgb: Vec::new(),
            bg_yuv: Vec::new(),
            identity: id,
        };
        scene.tex = Textures {
            iris: iris_texture(&scene.identity),
            sclera: sclera_texture(&scene.identity),
        };
        for k in 0..2 {
            scene.place_box(k);
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
        for k in 0..2 {
            let (x0, y0, w, h) = (
                scene.eyes[k].x0,
                scene.eyes[k].y0,
                scene.eyes[k].w,
                scene.eyes[k].h,
            );
            let mut b = Vec::with_capacity(w * h);
            for y in y0..y0 + h {
                b.extend_from_slice(&bg_lin[y * width + x0..y * width + x0 + w]);
            }
            scene.eyes[k].bg_lin = b;
            scene.make_lashes(k);
            scene.make_ball(k);
        }
        scene
    }

    /// Fills eye `k`'s per-pixel [`BallPx`]: the sclera as the ray tracer
    /// would see it with the eye looking straight ahead, in the head frame.
    fn make_ball(&mut self, k: usize) {
        let cam = self.camera;
        let r = &self.eyes[k];
        let o = cam.pos - r.model.centre;
        let radius = r.model.radius_mm;
        let light = self.light.f();
        // Beside the ball: flesh-tinted sclera curving into the canthus.
        let beside =
            f3(0.85, 0.62, 0.58).mulv(self.light_rgb * 0.45 + f3(1.0, 1.0, 1.0) * self.ambient);
        let mut ball = Vec::with_capacity(r.w * r.h);
        for y in 0..r.h {
            let py = (r.y0 + y) as f64 + 0.5;
            for x in 0..r.w {
                let px = (r.x0 + x) as f64 + 0.5;
                let d = (cam.fwd
                    + cam.right * ((px - cam.cx) / cam.f_px)
                    + cam.down * ((py - cam.cy) / cam.f_px))
                    .norm();
                let b = o.dot(d);
                let disc = b * b - (o.dot(o) - radius * radius);
                ball.push(if disc > 0.0 {
                    let n = ((o + d * (-b - disc.sqrt())) * (1.0 / radius)).f();
                    let (mul, add) = self.sclera_light(n, d.f(), light);
                    BallPx { n, mul, add }
                } else {
                    BallPx {
                        n: (o - d * b).norm().f(),
                        mul: beside,
                        add: f3(0.0, 0.0, 0.0),
                    }
                });
            }
        }
        self.eyes[k].ball = ball;
    }

    pub fn px_per_mm(&self) -> f64 {
        self.px_per_mm
    }

    /// Where each eye is in the image.
    pub fn geometry(&self) -> [EyeGeometry; 2] {
        [0, 1].map(|k| {
            let e = &self.eyes[k];
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

    pub fn background_yuv(&self) -> &[u8] {
        &self.bg_yuv
    }

    pub fn background_rgb(&self) -> &[u8] {
        &self.bg_rgb
    }

    fn lash_up_px(&self) -> f64 {
        // Lashes point toward the camera and curl; about half their length shows.
        self.identity.eye.lash_length_mm * 0.5 * self.px_per_mm
    }

    fn place_box(&mut self, k: usize) {
        let sh = self.identity.eye.clone();
        let m = self.eyes[k].model.clone();
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
        let e = &mut self.eyes[k];
        e.x0 = x0;
        e.y0 = y0;
        e.w = x1.saturating_sub(x0);
        e.h = y1.saturating_sub(y0);
        e.inner_corner_px = self.camera.project(m.lid_point(0.0, &open, true));
        e.outer_corner_px = self.camera.project(m.lid_point(1.0, &open, true));
    }

    /// Measures where the iris of eye `k` appears for a pose, normalized like
    /// the paper's eq. 1 (lids open, at the pose's vertical gaze).
    fn measure(&self, k: usize, pose: EyePose, closure: f64) -> EyeTruth {
        let m = &self.eyes[k].model;
        let rot = Basis::gaze(pose.yaw_rad, pose.pitch_rad);
        let iris = self.camera.project(m.iris_centre(&rot));
        let lids = m.lids(&self.identity.eye, pose.pitch_rad, closure);
        let top = self.camera.project(m.lid_point(0.5, &lids, true));
        let bot = self.camera.project(m.lid_point(0.5, &lids, false));
        let a = self.eyes[k].inner_corner_px;
        let b = self.eyes[k].outer_corner_px;
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

    /// Solves eye `k`'s rotation so that its measured normalized iris
    /// position equals `target` (Newton's method on the rendered projection;
    /// starts from the same guess every frame so frames are independent).
    pub fn solve_pose(&self, k: usize, target: NormPos) -> EyePose {
        let m = &self.eyes[k].model;
        let width_mm = (m.outer_x_mm - m.inner_x_mm).abs();
        let centre = self.measure(k, EyePose::default(), 0.0).norm;
        let mut yaw =
            (((target.nx - centre.nx) * width_mm / m.limbus_z_mm).clamp(-0.9, 0.9)).asin();
        let mut pitch = 0.0;
        let h = 1e-5;
        for _ in 0..12 {
            let p = EyePose {
                yaw_rad: yaw,
                pitch_rad: pitch,
            };
            let n0 = self.measure(k, p, 0.0).norm;
            let ex = n0.nx - target.nx;
            let ey = n0.ny - target.ny;
            if ex.abs() < 1e-10 && ey.abs() < 1e-10 {
                break;
            }
            let na = self
                .measure(
                    k,
                    EyePose {
                        yaw_rad: yaw + h,
                        ..p
                    },
                    0.0,
                )
                .norm;
            let nb = self
                .measure(
                    k,
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

    /// Ground truth of eye `k` for a pose and lid closure.
    pub fn truth(&self, k: usize, pose: EyePose, closure: f64) -> EyeTruth {
        self.measure(k, pose, closure)
    }

    /// The upper and lower lid margins of eye `k` for a pose and lid
    /// closure, in image pixels from the inner corner to the outer one
    /// (`n + 1` points each): where a landmark model should find the lids.
    pub fn lid_margins_px(
        &self,
        k: usize,
        pose: EyePose,
        closure: f64,
        n: usize,
    ) -> [Vec<[f64; 2]>; 2] {
        let m = &self.eyes[k].model;
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

    /// Renders both eye regions for one frame into `rgb` (full frame, sRGB,
    /// must start as a copy of the background) and/or `yuv` (full frame
    /// yuv420p, must start as a copy of the background yuv). Only the eye
    /// boxes are touched.
    pub fn render_eyes(
        &self,
        poses: [EyePose; 2],
        closure: f64,
        pupil_scale: f64,
        rgb: Option<&mut [u8]>,
        yuv: Option<&mut [u8]>,
        scratch: &mut Vec<u8>,
    ) {
        let mut rgb = rgb;
        let mut yuv = yuv;
        for (k, (r, pose)) in self.eyes.iter().zip(poses).enumerate() {
            if r.w == 0 || r.h == 0 {
                continue;
            }
            let ef = self.eye_frame(k, pose, closure, pupil_scale);
            let w = r.w;
            if let Some(frame) = rgb.as_deref_mut() {
                scratch.resize(r.w * r.h * 3, 0);
                scratch
                    .par_chunks_mut(w * 3 * 2)
                    .enumerate()
                    .for_each(|(pair, rows)| {
                        for (dy, row) in rows.chunks_mut(w * 3).enumerate() {
                            self.shade_row(&ef, pair * 2 + dy, row);
                        }
                    });
                for y in 0..r.h {
                    let dst = ((r.y0 + y) * self.width + r.x0) * 3;
                    frame[dst..dst + w * 3].copy_from_slice(&scratch[y * w * 3..(y + 1) * w * 3]);
                }
            }
            if let Some(planes) = yuv.as_deref_mut() {
                self.render_box_yuv(&ef, planes);
            }
        }
    }

    /// Renders both eye regions of one frame into yuv420p planes (which must
    /// hold this scene's background outside the eye boxes) on the calling
    /// thread only. Used when whole frames are rendered in parallel, which
    /// scales better than splitting a frame's rows across threads.
    pub fn render_eyes_yuv_serial(
        &self,
        poses: [EyePose; 2],
        closure: f64,
        pupil_scale: f64,
        yuv: &mut [u8],
    ) {
        for (k, (r, pose)) in self.eyes.iter().zip(poses).enumerate() {
            if r.w == 0 || r.h == 0 {
                continue;
            }
            let ef = self.eye_frame(k, pose, closure, pupil_scale);
            self.render_box_yuv_with(&ef, yuv, false);
        }
    }

    fn render_box_yuv(&self, ef: &EyeFrame, yuv: &mut [u8]) {
        self.render_box_yuv_with(ef, yuv, true)
    }

    /// Writes one eye box into yuv420p planes: the box is reset to the
    /// background, then only 2x2 blocks that the lids, lashes or eye can
    /// reach this frame are shaded.
    fn render_box_yuv_with(&self, ef: &EyeFrame, yuv: &mut [u8], parallel: bool) {
        let r = ef.r;
        let (w, h) = (self.width, self.height);
        let cw = w / 2;
        let (by, bw, bh) = (r.y0, r.w, r.h);
        let ranges: Vec<(f32, f32)> = (0..bw / 2)
            .map(|cx| {
                let a = self.active_rows(ef, cx * 2);
                let b = self.active_rows(ef, cx * 2 + 1);
                let (a, b) = (if a.1 > a.0 { a } else { b }, if b.1 > b.0 { b } else { a });
                (a.0.min(b.0), a.1.max(b.1))
            })
            .collect();
        let (yp, rest) = yuv.split_at_mut(w * h);
        let (up, vp) = rest.split_at_mut(cw * (h / 2));
        let ys = &mut yp[by * w..(by + bh) * w];
        let us = &mut up[(by / 2) * cw..(by + bh) / 2 * cw];
        let vs = &mut vp[(by / 2) * cw..(by + bh) / 2 * cw];
        if parallel {
            ys.par_chunks_mut(2 * w)
                .zip(us.par_chunks_mut(cw))
                .zip(vs.par_chunks_mut(cw))
                .enumerate()
                .for_each(|(pair, ((yrows, urow), vrow))| {
                    self.shade_row_pair(ef, &ranges, pair, yrows, urow, vrow)
                });
        } else {
            // Plain loops and `inline(always)` down to the pixel: with the
            // row body in a closure and the shading only hinted `inline`,
            // calls were left in the per-pixel path (a third of the render
            // CPU time that `eyereplay render --bench` prints).
            for (pair, ((yrows, urow), vrow)) in ys
                .chunks_mut(2 * w)
                .zip(us.chunks_mut(cw))
                .zip(vs.chunks_mut(cw))
                .enumerate()
            {
                self.shade_row_pair(ef, &ranges, pair, yrows, urow, vrow);
            }
        }
    }

    /// Box rows `2 pair` and `2 pair + 1`: the background, then the 2x2
    /// blocks whose columns' active rows (`ranges`, per block column) reach
    /// them. `yrows` holds the two full luma rows, `urow`/`vrow` the chroma row.
    #[inline(always)]
    fn shade_row_pair(
        &self,
        ef: &EyeFrame,
        ranges: &[(f32, f32)],
        pair: usize,
        yrows: &mut [u8],
        urow: &mut [u8],
        vrow: &mut [u8],
    ) {
        let r = ef.r;
        let (w, h) = (self.width, self.height);
        let cw = w / 2;
        let (bx, by, bw) = (r.x0, r.y0, r.w);
        let (bgy, bgrest) = self.bg_yuv.split_at(w * h);
        let (bgu, bgv) = bgrest.split_at(cw * (h / 2));
        let row = by + pair * 2;
        for dy in 0..2 {
            let o = (row + dy) * w + bx;
            yrows[dy * w + bx..dy * w + bx + bw].copy_from_slice(&bgy[o..o + bw]);
        }
        let co = (row / 2) * cw + bx / 2;
        urow[bx / 2..bx / 2 + bw / 2].copy_from_slice(&bgu[co..co + bw / 2]);
        vrow[bx / 2..bx / 2 + bw / 2].copy_from_slice(&bgv[co..co + bw / 2]);
        let (fy0, fy1) = ((pair * 2) as f32, (pair * 2 + 2) as f32);
        for (cx, &(a, b)) in ranges.iter().enumerate() {
            if fy1 <= a || fy0 >= b {
                continue;
            }
            let (x, y) = (cx * 2, pair * 2);
            let shaded = [
                self.shade_px(ef, x, y),
                self.shade_px(ef, x + 1, y),
                self.shade_px(ef, x, y + 1),
                self.shade_px(ef, x + 1, y + 1),
            ];
            if shaded.iter().all(Option::is_none) {
                continue; // the background copied above is exact
            }
            let (mut su, mut sv) = (0, 0);
            for (j, (dy, dx)) in [(0, 0), (0, 1), (1, 0), (1, 1)].into_iter().enumerate() {
                let c = match shaded[j] {
                    Some(c) => self.lut.rgb(c),
                    None => {
                        let i = ((row + dy) * w + bx + cx * 2 + dx) * 3;
                        [self.bg_rgb[i], self.bg_rgb[i + 1], self.bg_rgb[i + 2]]
                    }
                };
                let (yy, u, v) = yuv_of(c[0] as i32, c[1] as i32, c[2] as i32);
                yrows[dy * w + bx + cx * 2 + dx] = yy;
                su += u;
                sv += v;
            }
            urow[bx / 2 + cx] = chroma(su);
            vrow[bx / 2 + cx] = chroma(sv);
        }
    }

    fn eye_frame(&self, k: usize, pose: EyePose, closure: f64, pupil_scale: f64) -> EyeFrame<'_> {
        let r = &self.eyes[k];
        let m = &r.model;
        let rot = Basis::gaze(pose.yaw_rad, pose.pitch_rad);
        let lids = m.lids(&self.identity.eye, pose.pitch_rad, closure);
        // Project the lid curves and resample them per image column.
        const N: usize = 96;
        let mut up_pts = Vec::with_capacity(N + 1);
        let mut lo_pts = Vec::with_capacity(N + 1);
        for i in 0..=N {
            let s = i as f64 / N as f64;
            up_pts.push((self.camera.project(m.lid_point(s, &lids, true)), s));
            lo_pts.push((self.camera.project(m.lid_point(s, &lids, false)), s));
        }
        let mut up = vec![1e6f32; r.w];
        let mut lo = vec![-1e6f32; r.w];
        let mut s_col = vec![0f32; r.w];
        resample_columns(&up_pts, r.x0, &mut up, Some(&mut s_col));
        resample_columns(&lo_pts, r.x0, &mut lo, None);
        // Where the lower curve is missing (outside the corners), close.
        for x in 0..r.w {
            if lo[x] < -1e5 || up[x] > 1e5 {
                up[x] = 1e6;
                lo[x] = -1e6;
            }
        }
        let cam = &self.camera;
        let waterline_px = (0.9 * self.px_per_mm) as f32;
        // The eye darkens into both corners and into a narrow slit (the
        // lids shade it: no bright sclera line in a closing blink); the
        // pink caruncle fills the inner corner.
        let corner_col: Vec<(f32, f32)> = s_col
            .iter()
            .zip(up.iter().zip(&lo))
            .map(|(&s, (&u, &l))| {
                let slit = smoothstep(0.0, 0.6 * self.px_per_mm as f32, l - u);
                (
                    (0.55 + 0.45 * smoothstep(0.0, 0.22, s.min(1.0 - s))) * slit,
                    smoothstep(0.10, 0.02, s) * 0.85,
                )
            })
            .collect();
        let sk = self.identity.skin_rgb;
        let skin = f3(sk[0], sk[1], sk[2]);
        // A sphere about the limbus plane's centre holding the corneal cap.
        // The cornea's centre lies behind that plane, so along the cap the
        // distance from the plane's centre falls from the limbus rim to the
        // apex: the iris radius bounds it (plus a margin for the per-pixel
        // test's single precision).
        let cap_r = m.iris_radius_mm + 0.2;
        let cap_q = (m.centre + rot.z * m.limbus_z_mm) - cam.pos;
        EyeFrame {
            r,
            origin: rot.to_local(cam.pos - m.centre).f(),
            dir_fwd: rot.to_local(cam.fwd).f(),
            dir_right: rot.to_local(cam.right * (1.0 / cam.f_px)).f(),
            dir_down: rot.to_local(cam.down * (1.0 / cam.f_px)).f(),
            cx: cam.cx as f32,
            cy: cam.cy as f32,
            geo: EyeGeoF32 {
                radius: m.radius_mm as f32,
                iris_r: m.iris_radius_mm as f32,
                limbus_z: m.limbus_z_mm as f32,
                cornea_z: m.cornea_centre_z_mm as f32,
                cornea_r: CORNEA_RADIUS_MM as f32,
                iris_z: m.iris_z_mm as f32,
            },
            light: rot.to_local(self.light).f(),

            pupil_mm: (self.identity.eye.pupil_radius_mm * pupil_scale) as f32,
            up,
            lo,
            corner_col,
            origin_skip_mm: ((cam.pos - m.centre).len() - 30.0) as f32,
            axis_x: rot.x.f(),
            axis_y: rot.y.f(),
            ray_fwd: cam.fwd.f(),
            ray_right: (cam.right * (1.0 / cam.f_px)).f(),
            ray_down: (cam.down * (1.0 / cam.f_px)).f(),
            cap_q: cap_q.f(),
            cap_qq_minus_r2: (cap_q.dot(cap_q) - cap_r * cap_r) as f32,
            waterline_px,
            inv_shadow_px: 1.0 / (1.6 * self.px_per_mm) as f32,
            hair: F3 {
                x: self.identity.hair_rgb[0],
                y: self.identity.hair_rgb[1],
                z: self.identity.hair_rgb[2],
            }
            .mulv(self.light_rgb * 0.5 + f3(1.0, 1.0, 1.0) * self.ambient),
            // Mucosa is pink, but darker skin has darker lid margins.
            wet: f3(0.5, 0.26, 0.23)
                .lerp(skin.mulv(f3(1.1, 0.85, 0.85)), 0.45)
                .mulv(self.light_rgb * 0.7 + f3(1.0, 1.0, 1.0) * self.ambient),
            caruncle: f3(0.55, 0.22, 0.2)
                .lerp(skin.mulv(f3(1.1, 0.8, 0.8)), 0.35)
                .mulv(self.light_rgb * 0.6 + f3(1.0, 1.0, 1.0) * self.ambient),
        }
    }

    /// Shades one row (box-relative `y`) of an eye box into sRGB bytes.
    fn shade_row(&self, ef: &EyeFrame, y: usize, out: &mut [u8]) {
        let r = ef.r;
        for x in 0..r.w {
            let rgb = match self.shade_px(ef, x, y) {
                Some(c) => self.lut.rgb(c),
                None => {
                    let i = ((r.y0 + y) * self.width + r.x0 + x) * 3;
                    [self.bg_rgb[i], self.bg_rgb[i + 1], self.bg_rgb[i + 2]]
                }
            };
            out[x * 3..x * 3 + 3].copy_from_slice(&rgb);
        }
    }

    /// Rows (box-relative, half-open) of column `x` that can differ from
    /// the background this frame: lashes above the upper lid down to the
    /// lower lashes.
    #[inline(always)]
    fn active_rows(&self, ef: &EyeFrame, x: usize) -> (f32, f32) {
        let up = ef.up[x];
        if up > 1e5 {
            return (0.0, 0.0);
        }
        let y0 = ef.r.y0 as f32;
        (
            up - ef.r.up_reach[x] - 1.0 - y0,
            ef.lo[x] + ef.r.lo_reach[x] + 1.0 - y0,
        )
    }

    /// Shades one pixel (box-relative) in linear RGB; `None` where it shows
    /// the background unchanged.
    #[inline(always)]
    fn shade_px(&self, ef: &EyeFrame, x: usize, y: usize) -> Option<F3> {
        let r = ef.r;
        let py = (r.y0 + y) as f32 + 0.5;
        let du = py - ef.up[x]; // > 0 below the upper margin
        let dl = ef.lo[x] - py; // > 0 above the lower margin
        if du < -r.up_reach[x] || dl < -r.lo_reach[x] {
            return None;
        }
        let bgc = r.bg_lin[y * r.w + x];
        let wl_px = ef.waterline_px;
        let mut col = bgc;
        // Pixels nothing below touches stay the background, and the caller
        // can skip their colour conversion (gaps between lashes, mostly).
        let mut touched = false;
        // The eye, with anti-aliased lid edges.
        let cover = clamp01(du + 0.5) * clamp01(dl + 0.5);
        if cover > 0.0 {
            touched = true;
            let px = (r.x0 + x) as f32 + 0.5;
            let mut e = self.shade_eyeball(ef, x, y, px, py);
            // Upper-lid and lash shadow on the eye, a softer one from the lower lid.
            let sh = 1.0
                - 0.6 * soft_falloff(du.max(0.0) * ef.inv_shadow_px)
                - 0.2 * soft_falloff(dl.max(0.0) * 2.0 * ef.inv_shadow_px);
            // Caruncle and corner shadow (per column, see `eye_frame`).
            let (corner, car) = ef.corner_col[x];
            e = e * (sh * corner);
            e = e.lerp(ef.caruncle, car);
            col = col.lerp(e, cover);
        }
        // Wet lower-lid margin (waterline) just below the aperture.
        if dl < 0.0 && dl > -wl_px - 1.0 && du > 0.0 {
            touched = true;
            let t = -dl / wl_px;
            let a = (1.0 - smoothstep(0.7, 1.0, t)) * clamp01(-dl + 0.5);
            col = col.lerp(ef.wet, a * 0.9);
            // A thin specular streak on the tear film.
            let q = (t - 0.25) * 6.0;
            col = col + self.light_rgb * (fast_exp(-q * q) * 0.25);
        }
        // Lash line and upper lashes (texture rows relative to the margin).
        let d_up = -du + LASH_ROOT_PX as f32;
        if d_up >= 0.0 && d_up < r.lash_up_rows as f32 {
            let a = r.lash_up[d_up as usize * r.w + x];
            if a > 0.0 {
                touched = true;
                col = col.lerp(ef.hair, a);
            }
        }
        let d_lo = -dl - wl_px * 0.6;
        if d_lo >= 0.0 && d_lo < r.lash_lo_rows as f32 {
            let a = r.lash_lo[d_lo as usize * r.w + x];
            if a > 0.0 {
                touched = true;
                col = col.lerp(ef.hair, a * 0.8);
            }
        }
        touched.then_some(col)
    }

    /// The eyeball at box pixel (x, y), image point (px, py); linear RGB.
    /// Only rays that can meet the corneal cap are traced; the sclera comes
    /// from the pixel's precomputed [`BallPx`].
    #[inline(always)]
    fn shade_eyeball(&self, ef: &EyeFrame, x: usize, y: usize, px: f32, py: f32) -> F3 {
        if may_meet_cornea(ef, px, py) {
            if let Some(c) = self.shade_cornea(ef, px, py) {
                return c;
            }
        }
        let b = &ef.r.ball[y * ef.r.w + x];
        let tex = sample_nearest(
            &self.tex.sclera,
            SCLERA_TEX,
            b.n.dot(ef.axis_x),
            b.n.dot(ef.axis_y),
        );
        tex.mulv(b.mul) + b.add
    }

    /// Ray-traces the cornea, the iris behind it and the limbus at image
    /// point (px, py); `None` where the ray does not meet the corneal cap.
    ///
    /// In f32: the ray starts 30 mm before the eye (so the quadratics do not
    /// lose precision to the 400+ mm camera distance), and single precision
    /// halves the latency of the square roots and divisions that dominate.
    #[inline(always)]
    fn shade_cornea(&self, ef: &EyeFrame, px: f32, py: f32) -> Option<F3> {
        let g = &ef.geo;
        let d = ef.dir_fwd + ef.dir_right * (px - ef.cx) + ef.dir_down * (py - ef.cy);
        let d = d * (1.0 / d.dot(d).sqrt());
        let o = ef.origin + d * ef.origin_skip_mm;
        let light = ef.light;
        let lc = self.light_rgb;
        let amb = self.ambient;
        let oc = f3(o.x, o.y, o.z - g.cornea_z);
        let b = oc.dot(d);
        let c = oc.dot(oc) - g.cornea_r * g.cornea_r;
        let disc = b * b - c;
        if disc <= 0.0 {
            return None;
        }
        let t = -b - disc.sqrt();
        let p = o + d * t;
        if p.z < g.limbus_z {
            return None;
        }
        let n = f3(p.x, p.y, p.z - g.cornea_z) * (1.0 / g.cornea_r);
        let cosi = -d.dot(n);
        // Refraction into the aqueous humour, then hit the iris plane.
        let eta = 1.0 / CORNEA_INDEX as f32;
        let k = 1.0 - eta * eta * (1.0 - cosi * cosi);
        let tr = d * eta + n * (eta * cosi - k.max(0.0).sqrt());
        let s = (g.iris_z - p.z) / tr.z;
        let q = p + tr * s;
        let r2 = q.x * q.x + q.y * q.y;
        let ri = g.iris_r;
        let pr = ef.pupil_mm;
        let iris_light = amb + 0.75 * (0.4 + 0.6 * light.z.max(0.0));
        let mut col = if r2 < pr * pr {
            f3(0.006, 0.005, 0.005)
        } else if r2 < ri * ri {
            let tex = sample_bilinear(&self.tex.iris, IRIS_TEX, q.x / ri, q.y / ri);
            // Dark pupillary ruff right at the pupil edge.
            let ruff = smoothstep(pr * 1.12, pr, r2.sqrt());
            tex.lerp(f3(0.03, 0.02, 0.015), ruff * 0.8) * iris_light
        } else {
            f3(0.05, 0.045, 0.045) * iris_light
        };
        col = col.mulv(lc * 0.7 + f3(1.0, 1.0, 1.0) * 0.3);
        // Blend into the sclera over the last 0.3 mm at the limbus.
        let edge = smoothstep(g.limbus_z, g.limbus_z + 0.3, p.z);
        if edge < 1.0 {
            let on_ball = p * (g.radius / p.dot(p).sqrt());
            col = self.sclera_color(ef, on_ball, d).lerp(col, edge);
        }
        // Corneal reflections: the key light's glint and a faint room.
        let refl = d + n * (2.0 * cosi);
        let glint = smoothstep(0.9965, 0.9985, refl.dot(light)) * 2.2;
        // A dim, even room reflection growing toward grazing angles.
        let fresnel = 0.02 + 0.2 * (1.0 - cosi).powi(4);
        let env = f3(0.5, 0.5, 0.55) * fresnel;
        Some(col + lc * glint + env)
    }

    #[inline(always)]
    fn sclera_color(&self, ef: &EyeFrame, p: F3, d: F3) -> F3 {
        let n = p * (1.0 / ef.geo.radius);
        let tex = sample_nearest(&self.tex.sclera, SCLERA_TEX, n.x, n.y);
        let (mul, add) = self.sclera_light(n, d, ef.light);
        tex.mulv(mul) + add
    }

    /// Lighting of the sclera at unit normal `n` seen along `d`: colour =
    /// texel * `mul` + `add`. Only dot products of `n`, `d` and `light`
    /// enter, so any common frame works (eye frame per pixel at the limbus,
    /// head frame once per session in [`BallPx`]).
    #[inline(always)]
    fn sclera_light(&self, n: F3, d: F3, light: F3) -> (F3, F3) {
        let ndl = n.dot(light);
        let ndv = -n.dot(d);
        let diffuse = self.ambient + 0.8 * ((ndl + 0.25) / 1.25).max(0.0);
        let rim = 0.45 + 0.55 * ndv.max(0.0);
        let refl = d + n * (2.0 * ndv);
        let spec = smoothstep(0.992, 0.998, refl.dot(light)) * 0.6;
        (
            (self.light_rgb * diffuse + f3(1.0, 1.0, 1.0) * (self.ambient * 0.3)) * rim,
            self.light_rgb * spec,
        )
    }

    /// The static face: skin with shading of the orbits, brows, lid creases
    /// and the eyeballs under the lids (seen when the lids close). Linear RGB.
    fn background(&self) -> Vec<F3> {
        let id = &self.identity;
        let sh = &id.eye;
        let (w, h) = (self.width, self.height);
        let cam = self.camera;
        let noise = Noise2::new(id.seed ^ 0x5C1);
        let pores = Noise2::new(id.seed ^ 0x9023);
        let skin = f3(id.skin_rgb[0], id.skin_rgb[1], id.skin_rgb[2]);
        let half_ipd = sh.ipd_mm / 2.0;
        let er = sh.eyeball_radius_mm;
        // Face plane point for every pixel (z = 10 mm, the skin around the eyes).
        let plane_z = 10.0;
        let face_xy = |u: f64, v: f64| -> (f64, f64) {
            let d = cam.fwd
                + cam.right * ((u - cam.cx) / cam.f_px)
                + cam.down * ((v - cam.cy) / cam.f_px);
            let t = (plane_z - cam.pos.z) / d.z;
            let p = cam.pos + d * t;
            (p.x, p.y)
        };
        let eyes = [&self.eyes[0].model, &self.eyes[1].model];
        let open: Vec<LidState> = eyes.iter().map(|m| m.lids(sh, 0.0, 0.0)).collect();
        let height_mm = |x: f64, y: f64| -> f64 {
            let mut hgt = 0.0;
            for ex in [-half_ipd, half_ipd] {
                let dx = x - ex;
                // Orbit hollow, deepest just above the eye under the brow.
                hgt -= 5.0
                    * (-(dx * dx / (2.0 * 16.0f64.powi(2))
                        + (y + 3.0).powi(2) / (2.0 * 11.0f64.powi(2))))
                    .exp();
                // The eyeball under the lids.
                // Smooth at its rim so it shades like a lid over a ball.
                let q = 1.0 - (dx * dx / 1.5 + y * y) / (er * er * 1.2);
                if q > 0.0 {
                    hgt += 2.6 * q * q * q;
                }
                // Brow ridge.
                let by = y + sh.brow_height_mm - 2.0;
                hgt += 3.5
                    * (-(by * by) / (2.0 * 6.0f64.powi(2))).exp()
                    * (-(dx * dx) / (2.0 * 26.0f64.powi(2))).exp();
                // Cheek and lower-lid roll.
                hgt += 4.0
                    * (-((dx * 1.1 - ex.signum() * 4.0).powi(2) / (2.0 * 18.0f64.powi(2))
                        + (y - 27.0).powi(2) / (2.0 * 9.0f64.powi(2))))
                    .exp();
                hgt += 0.7
                    * (-(dx * dx / (2.0 * 9.0f64.powi(2))
                        + (y - 8.5).powi(2) / (2.0 * 1.8f64.powi(2))))
                    .exp();
            }
            // Nose bridge rising toward the tip.
            hgt += 9.0
                * (-(x * x) / (2.0 * 7.5f64.powi(2))).exp()
                * smoothstep(-35.0, 30.0, y as f32) as f64;
            hgt
        };
        // Slowly varying fields (shape normals, mottling, redness, the dark
        // skin around the eyes) on a coarse grid, interpolated per pixel:
        // evaluating them per pixel dominated the set-up time.
        const STEP: usize = 4;
        let (gw, gh) = (w / STEP + 2, h / STEP + 2);
        let mm_per_px = 1.0 / self.px_per_mm;
        let dmm = STEP as f64 * mm_per_px;
        let slow: Vec<[f32; 6]> = (0..gw * gh)
            .into_par_iter()
            .map(|i| {
                let (u, v) = (((i % gw) * STEP) as f64, ((i / gw) * STEP) as f64);
                let (x, y) = face_xy(u, v);
                // Normal from the height field by central differences.
                let hx = height_mm(x + dmm, y) - height_mm(x - dmm, y);
                let hy = height_mm(x, y + dmm) - height_mm(x, y - dmm);
                let n = v3(-hx / (2.0 * dmm), -hy / (2.0 * dmm), 1.0).norm();
                let (xf, yf) = (x as f32, y as f32);
                // Rotated sample coordinates hide the noise lattice's axes.
                let (rx, ry) = (0.8 * xf + 0.6 * yf, -0.6 * xf + 0.8 * yf);
                let mottle = noise.fbm(rx / 9.0, ry / 9.0, 3);
                let red = noise.fbm(ry / 14.0 + 40.0, rx / 14.0, 3);
                let mut peri = 0.0f32;
                for ex in [-half_ipd, half_ipd] {
                    let dx = (x - ex) as f32;
                    let dy = y as f32 + 1.0;
                    peri += (-(dx * dx / 300.0 + dy * dy / 110.0)).exp();
                }
                [n.x as f32, n.y as f32, n.z as f32, mottle, red, peri]
            })
            .collect();
        let coords: Vec<(f64, f64)> = (0..w * h)
            .into_par_iter()
            .map(|i| face_xy((i % w) as f64 + 0.5, (i / w) as f64 + 0.5))
            .collect();
        let light = self.light;
        let lrgb = self.light_rgb;
        let amb = self.ambient;
        let brow = self.brow_alpha();
        let hair = f3(id.hair_rgb[0], id.hair_rgb[1], id.hair_rgb[2]);
        // Crease curves: per eye, in mm, sampled densely for a lookup by x.
        let creases: Vec<Vec<(f64, f64)>> = eyes
            .iter()
            .zip(&open)
            .map(|(m, l)| {
                (0..=64)
                    .map(|i| {
                        let s = i as f64 / 64.0;
                        let p = m.lid_point(s, l, true);
                        let lift = sh.crease_mm * (std::f64::consts::PI * s).sin().powf(0.7);
                        (p.x, p.y - lift)
                    })
                    .collect()
            })
            .collect();
        // Fine lines under each eye: curves following the lower lid, a few
        // millimetres below it, each fading out at its ends.
        let mut wr = SplitMix64::new(id.seed ^ 0x3A1);
        let under_lines: Vec<(Vec<(f64, f64)>, f32)> = eyes
            .iter()
            .zip(&open)
            .flat_map(|(m, l)| {
                let depth = [wr.range(2.2, 3.2), wr.range(4.0, 5.5)];
                let strength = [wr.range(0.1, 0.2) as f32, wr.range(0.06, 0.14) as f32];
                (0..2)
                    .map(|j| {
                        let pts = (0..=64)
                            .map(|i| {
                                let s = 0.15 + 0.8 * i as f64 / 64.0;
                                let p = m.lid_point(s, l, false);
                                (
                                    p.x,
                                    p.y + depth[j] * (0.6 + 0.4 * (std::f64::consts::PI * s).sin()),
                                )
                            })
                            .collect();
                        (pts, strength[j])
                    })
                    .collect::<Vec<_>>()
            })
            .collect();
        (0..w * h)
            .into_par_iter()
            .map(|i| {
                let (x, y) = coords[i];
                let (px, py) = (i % w, i / w);
                let (gx, gy) = (px / STEP, py / STEP);
                let (tx, ty) = (
                    ((px % STEP) as f32 + 0.5) / STEP as f32,
                    ((py % STEP) as f32 + 0.5) / STEP as f32,
                );
                let g = |dx: usize, dy: usize| &slow[(gy + dy) * gw + gx + dx];
                let mut f = [0f32; 6];
                for (k, v) in f.iter_mut().enumerate() {
                    let top = g(0, 0)[k] + (g(1, 0)[k] - g(0, 0)[k]) * tx;
                    let bot = g(0, 1)[k] + (g(1, 1)[k] - g(0, 1)[k]) * tx;
                    *v = top + (bot - top) * ty;
                }
                let [nx, ny, nz, mottle, red, peri] = f;
                let n = v3(nx as f64, ny as f64, nz as f64).norm();
                let ndl = n.dot(light) as f32;
                let diffuse = ((ndl + 0.35) / 1.35).max(0.0);
                // Albedo: mottling, pores, darker and redder skin around the eyes.
                let (xf, yf) = (x as f32, y as f32);
                let pore = pores.value(xf * 2.2, yf * 2.2).max(0.0);
                let fine = pores.value(0.8 * yf + 11.0, 0.8 * xf);
                let mut alb = skin.mulv(f3(
                    1.0 + 0.035 * mottle + 0.025 * red,
                    1.0 + 0.035 * mottle - 0.015 * red,
                    1.0 + 0.035 * mottle - 0.015 * red,
                )) * (1.0 - 0.09 * pore + 0.015 * fine);
                alb = alb.mulv(f3(1.0 - 0.10 * peri, 1.0 - 0.17 * peri, 1.0 - 0.15 * peri));
                // Lid crease: a soft dark fold with a lighter lid below it.
                let mut crease = 0.0f32;
                for c in &creases {
                    if let Some((sx, cy)) = curve_at(c, x) {
                        let dy = (y - cy) as f32;
                        // The fold fades out toward the corners.
                        let fade = (std::f32::consts::PI * sx).sin().max(0.0).powf(1.5);
                        // Dark fold, shadow above it (the brow's overhang), a
                        // lighter convex lid below.
                        crease += fade
                            * ((-(dy / 0.7).powi(2)).exp() * 0.32
                                + (-(dy / 2.2).powi(2)).exp() * if dy < 0.0 { 0.2 } else { -0.1 });
                    }
                }
                for (c, strength) in &under_lines {
                    if let Some((sx, cy)) = curve_at(c, x) {
                        let dy = (y - cy) as f32;
                        if dy.abs() < 1.0 {
                            let fade = (std::f32::consts::PI * sx).sin();
                            // A thin dark fold with a faint lit edge below it.
                            crease += strength
                                * fade
                                * ((-(dy / 0.13).powi(2)).exp()
                                    - 0.4 * (-((dy - 0.25) / 0.15).powi(2)).exp());
                        }
                    }
                }
                let crease = crease.clamp(-0.3, 0.8);
                let shade = lrgb * (diffuse * (1.0 - crease))
                    + f3(1.0, 1.0, 1.0) * (amb * (1.0 - 0.6 * crease));
                let mut col = alb.mulv(shade);
                // A faint sheen on the skin.
                let hv = (light + v3(0.0, 0.0, 1.0)).norm();
                let spec = (n.dot(hv).max(0.0) as f32).powi(24) * 0.035 * (1.0 - 0.6 * pore);
                col = col + lrgb * spec;
                let b = brow[i];
                if b > 0.0 {
                    col = col.lerp(hair.mulv(shade) * 0.9, b);
                }
                // Slight lens vignetting.
                let vx = (px as f32 / w as f32 - 0.5) * 2.0;
                let vy = (py as f32 / h as f32 - 0.5) * 2.0;
                col * (1.0 - 0.12 * (vx * vx + vy * vy) * 0.5)
            })
            .collect()
    }

    /// Brow hairs as an alpha map over the image.
    fn brow_alpha(&self) -> Vec<f32> {
        let id = &self.identity;
        let sh = &id.eye;
        let (w, h) = (self.width, self.height);
        let mut alpha = vec![0f32; w * h];
        let mut rng = SplitMix64::new(id.seed ^ 0xB80);
        for side in [-1.0f64, 1.0] {
            let ex = side * sh.ipd_mm / 2.0;
            for _ in 0..1500 {
                // Along the brow: t = 0 at the nasal head, 1 at the tail.
                let t = rng.f64();
                let x_mm = ex - side * 17.0 + side * t * 38.0;
                let arch = -sh.brow_height_mm
                    - 4.0 * (std::f64::consts::PI * (t * 0.9 + 0.05)).sin()
                    + 3.0;
                // Thick body, thin head and tail.
                let thick = sh.brow_thickness_mm
                    * (0.55 + 0.45 * (std::f64::consts::PI * (0.15 + 0.8 * t)).sin());
                let y_mm = arch + (rng.f64() - 0.5) * thick;
                // Hairs stand up at the head and turn to lie along the brow.
                let ang =
                    -1.25 + 1.05 * smoothstep(0.0, 0.3, t as f32) as f64 + rng.range(-0.2, 0.2);
                let len = rng.range(3.0, 6.5)
                    * (1.0 - 0.35 * (1.0 - smoothstep(0.0, 0.25, t as f32) as f64));
                let (sa, ca) = ang.sin_cos();
                let a = v3(x_mm, y_mm, 10.0);
                let bend = rng.range(0.05, 0.25);
                let pts: Vec<[f64; 2]> = (0..=6)
                    .map(|j| {
                        let f = j as f64 / 6.0;
                        let dx = side * ca * len * f;
                        let dy = sa * len * f + bend * len * f * f;
                        self.camera.project(a + v3(dx, dy, 0.0))
                    })
                    .collect();
                let width_px = 0.09 * self.px_per_mm;
                let opacity = rng.range(0.3, 0.7) as f32 * (1.0 - 0.4 * t as f32);
                draw_strand(&mut alpha, w, h, &pts, width_px, opacity);
            }
        }
        alpha
    }

    /// Draws upper and lower lashes into eye `k`'s lash textures.
    fn make_lashes(&mut self, k: usize) {
        let id = self.identity.clone();
        let sh = &id.eye;
        let r = &self.eyes[k];
        let w = r.w;
        let up_rows = (self.lash_up_px().ceil() as usize + LASH_ROOT_PX + 2).min(r.h);
        let lo_rows = ((self.lash_up_px() * 0.4).ceil() as usize + 2).min(r.h);
        let mut up = vec![0f32; w * up_rows];
        let mut lo = vec![0f32; w * lo_rows];
        let m = r.model.clone();
        let open = m.lids(sh, 0.0, 0.0);
        let mut rng = SplitMix64::new(id.seed ^ (0x1A5 + k as u64));
        let px_mm = self.px_per_mm;
        // Which image direction is "outer" for this eye.
        let outer_dir = if m.side == Side::Left { -1.0 } else { 1.0 };
        let lash_px = self.lash_up_px();
        let col_of = |s: f64| -> f64 {
            let p = self.camera.project(m.lid_point(s, &open, true));
            p[0] - r.x0 as f64
        };
        // The dense lash line along the margin.
        for x in 0..w {
            for row in 0..up_rows {
                let d = row as f64 - LASH_ROOT_PX as f64;
                let line = (-(d / (0.45 * px_mm)).powi(2)).exp() as f32 * 0.85;
                up[row * w + x] = line;
            }
        }
        // Fade the lash line out at the corners.
        let c0 = col_of(0.0);
        let c1 = col_of(1.0);
        let (ca, cb) = (c0.min(c1), c0.max(c1));
        for x in 0..w {
            let fx = x as f64;
            let fade = smoothstep(ca as f32, (ca + 0.12 * (cb - ca)) as f32, fx as f32)
                * smoothstep(cb as f32, (cb - 0.12 * (cb - ca)) as f32, fx as f32);
            for row in 0..up_rows {
                up[row * w + x] *= fade;
            }
        }
        for _ in 0..sh.lash_count {
            // Denser and longer toward the middle and outer third.
            let s = 0.06 + 0.92 * rng.f64().powf(0.85);
            let base_x = col_of(s) + rng.range(-1.0, 1.0);
            let len =
                lash_px * (0.45 + 0.55 * (std::f64::consts::PI * s).sin()) * rng.range(0.75, 1.1);
            let lean = outer_dir * (-0.15 + 0.85 * s) + rng.range(-0.15, 0.15);
            let curl = outer_dir * rng.range(0.1, 0.35);
            let pts: Vec<[f64; 2]> = (0..=8)
                .map(|j| {
                    let f = j as f64 / 8.0;
                    let dx = len * f * (lean * 0.6) + curl * len * f * f;
                    let dy = len * (f - 0.15 * f * f);
                    [base_x + dx, LASH_ROOT_PX as f64 - 0.5 + dy]
                })
                .collect();
            draw_strand(
                &mut up,
                w,
                up_rows,
                &pts,
                0.16 * px_mm,
                rng.range(0.75, 1.0) as f32,
            );
        }
        for _ in 0..sh.lash_count / 3 {
            let s = 0.25 + 0.72 * rng.f64();
            let base_x = col_of(s) + rng.range(-1.0, 1.0);
            let len = lash_px * 0.35 * rng.range(0.6, 1.1);
            let lean = outer_dir * (0.1 + 0.5 * s) + rng.range(-0.2, 0.2);
            let pts: Vec<[f64; 2]> = (0..=5)
                .map(|j| {
                    let f = j as f64 / 5.0;
                    [base_x + len * f * lean * 0.6, len * f]
                })
                .collect();
            draw_strand(
                &mut lo,
                w,
                lo_rows,
                &pts,
                0.07 * px_mm,
                rng.range(0.4, 0.8) as f32,
            );
        }
        // Alpha below half an 8-bit step cannot change a pixel: make it
        // exactly zero so those pixels are recognised as background.
        for a in up.iter_mut().chain(lo.iter_mut()) {
            if *a < 1.0 / 512.0 {
                *a = 0.0;
            }
        }
        let wl = 0.9 * px_mm as f32;
        let max_row = |tex: &[f32], rows: usize, x: usize| {
            (0..rows)
                .rev()
                .find(|&r| tex[r * w + x] > 1.0 / 512.0)
                .map(|r| r as f32)
        };
        let up_reach = (0..w)
            .map(|x| {
                max_row(&up, up_rows, x).map_or(1.0, |r| (r - LASH_ROOT_PX as f32 + 2.0).max(1.0))
            })
            .collect();
        let lo_reach = (0..w)
            .map(|x| {
                let lash = max_row(&lo, lo_rows, x).map_or(0.0, |r| wl * 0.6 + r + 2.0);
                lash.max(wl + 1.5)
            })
            .collect();
        let e = &mut self.eyes[k];
        e.up_reach = up_reach;
        e.lo_reach = lo_reach;
        e.lash_up = up;
        e.lash_up_rows = up_rows;
        e.lash_lo = lo;
        e.lash_lo_rows = lo_rows;
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

/// A skin curve sampled at points evenly spaced in x (image px): where column
/// `x` falls along it (0..1) and the curve's y there; `None` outside it.
fn curve_at(c: &[(f64, f64)], x: f64) -> Option<(f32, f64)> {
    let n = (c.len() - 1) as f64;
    let (first, last) = (c[0].0, c[c.len() - 1].0);
    if x <= first.min(last) || x >= first.max(last) {
        return None;
    }
    let f = ((x - first) / (last - first) * n).clamp(0.0, n - 0.001);
    let j = f as usize;
    Some((
        (f / n) as f32,
        c[j].1 + (c[j + 1].1 - c[j].1) * (f - j as f64),
    ))
}

/// Whether the ray of image point (px, py) passes within the sphere that
/// bounds the corneal cap: its squared distance from the sphere's centre,
/// `|q|^2 - (q.d)^2 / |d|^2`, below `r_bound^2`, without a root or division.
#[inline(always)]
fn may_meet_cornea(ef: &EyeFrame, px: f32, py: f32) -> bool {
    let d = ef.ray_fwd + ef.ray_right * (px - ef.cx) + ef.ray_down * (py - ef.cy);
    let qd = ef.cap_q.dot(d);
    qd * qd > ef.cap_qq_minus_r2 * d.dot(d)
}

/// Linear interpolation of a projected curve (points with parameter s) at
/// every integer column centre of a box starting at `x0`.
fn resample_columns(
    pts: &[([f64; 2], f64)],
    x0: usize,
    out: &mut [f32],
    mut s_out: Option<&mut [f32]>,
) {
    let mut p: Vec<([f64; 2], f64)> = pts.to_vec();
    if p.first().map(|a| a.0[0]) > p.last().map(|a| a.0[0]) {
        p.reverse();
    }
    let mut j = 0;
    for (x, o) in out.iter_mut().enumerate() {
        let u = (x0 + x) as f64 + 0.5;
        if u < p[0].0[0] || u > p[p.len() - 1].0[0] {
            continue;
        }
        while j + 1 < p.len() - 1 && p[j + 1].0[0] < u {
            j += 1;
        }
        let (a, b) = (p[j], p[j + 1]);
        let dx = b.0[0] - a.0[0];
        let t = if dx.abs() < 1e-9 {
            0.0
        } else {
            (u - a.0[0]) / dx
        };
        *o = (a.0[1] + t * (b.0[1] - a.0[1])) as f32;
        if let Some(s) = s_out.as_deref_mut() {
            s[x] = (a.1 + t * (b.1 - a.1)) as f32;
        }
    }
}

/// Draws an anti-aliased tapered polyline into an alpha map (max blend).
fn draw_strand(
    alpha: &mut [f32],
    w: usize,
    h: usize,
    pts: &[[f64; 2]],
    width_px: f64,
    opacity: f32,
) {
    let n = pts.len() - 1;
    for i in 0..n {
        let (a, b) = (pts[i], pts[i + 1]);
        let taper = 1.0 - 0.8 * (i as f64 / n as f64);
        let half = (width_px * taper * 0.5).max(0.3);
        let x0 = (a[0].min(b[0]) - half - 1.0).floor().max(0.0) as usize;
        let x1 = ((a[0].max(b[0]) + half + 1.0).ceil().max(0.0) as usize).min(w);
        let y0 = (a[1].min(b[1]) - half - 1.0).floor().max(0.0) as usize;
        let y1 = ((a[1].max(b[1]) + half + 1.0).ceil().max(0.0) as usize).min(h);
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        let len2 = (dx * dx + dy * dy).max(1e-9);
        // Thin hairs cover less than a pixel: scale opacity by width.
        let op = opacity * (half * 2.0).min(1.0) as f32;
        for y in y0..y1 {
            for x in x0..x1 {
                let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
                let t = (((px - a[0]) * dx + (py - a[1]) * dy) / len2).clamp(0.0, 1.0);
                let (qx, qy) = (a[0] + t * dx - px, a[1] + t * dy - py);
                let dist = (qx * qx + qy * qy).sqrt();
                let cov = (half + 0.5 - dist).clamp(0.0, 1.0) as f32 * op;
                let v = &mut alpha[y * w + x];
                *v = *v + cov * (1.0 - *v) * if cov > *v { 1.0 } else { 0.35 };
            }
        }
    }
}

/// A smooth falloff from 1 at 0 toward 0, close to exp(-u) for small u
/// (the reciprocal of exp's Taylor series to third order): one division
/// instead of an exponential for the per-pixel lid shadows.
#[inline(always)]
fn soft_falloff(u: f32) -> f32 {
    1.0 / (1.0 + u * (1.0 + u * (0.5 + u * (1.0 / 6.0))))
}

/// exp(x) for x <= 0 to about 1e-4 relative accuracy; the shading only
/// needs smooth falloffs and libm's exp dominated the profile.
#[inline(always)]
fn fast_exp(x: f32) -> f32 {
    if x < -30.0 {
        return 0.0;
    }
    // 2^(x log2 e) split into integer and fractional parts.
    let t = x * std::f32::consts::LOG2_E;
    let i = floor_fast(t);
    let f = t - i;
    let p = 1.0
        + f * (std::f32::consts::LN_2 + f * (0.240_226_5 + f * (0.055_504_1 + f * 0.009_618_1)));
    p * f32::from_bits((((i as i32) + 127) << 23) as u32)
}

#[inline(always)]
fn sample_bilinear(tex: &[F3], n: usize, u: f32, v: f32) -> F3 {
    // u, v in [-1, 1] map to texel centres across the texture.
    let fx = ((u + 1.0) * 0.5 * (n - 1) as f32).clamp(0.0, (n - 1) as f32 - 0.001);
    let fy = ((v + 1.0) * 0.5 * (n - 1) as f32).clamp(0.0, (n - 1) as f32 - 0.001);
    let (ix, iy) = (fx as usize, fy as usize);
    let (tx, ty) = (fx - ix as f32, fy - iy as f32);
    let i = iy * n + ix;
    let top = tex[i].lerp(tex[i + 1], tx);
    let bot = tex[i + n].lerp(tex[i + n + 1], tx);
    top.lerp(bot, ty)
}

#[inline(always)]
fn sample_nearest(tex: &[F3], n: usize, u: f32, v: f32) -> F3 {
    let ix = (((u + 1.0) * 0.5 * n as f32) as isize).clamp(0, n as isize - 1) as usize;
    let iy = (((v + 1.0) * 0.5 * n as f32) as isize).clamp(0, n as isize - 1) as usize;
    tex[iy * n + ix]
}

/// Iris: two-zone colour split at a wavy collarette, radial fibres, crypts,
/// concentric furrows and a dark limbal ring.
fn iris_texture(id: &Identity) -> Vec<F3> {
    let st = &id.iris;
    let n = IRIS_TEX;
    let fib = Noise2::new(id.seed ^ 0x1815);
    let fib2 = Noise2::new(id.seed ^ 0x1816);
    let mut rng = SplitMix64::new(id.seed ^ 0xC8F7);
    let crypts: Vec<(f32, f32, f32)> = (0..st.crypt_count)
        .map(|_| {
            (
                rng.f32r(0.0, 1.0),
                rng.f32r(st.collarette_frac + 0.05, 0.85),
                rng.f32r(0.02, 0.06),
            )
        })
        .collect();
    let outer = f3(st.outer_rgb[0], st.outer_rgb[1], st.outer_rgb[2]);
    let inner = f3(st.inner_rgb[0], st.inner_rgb[1], st.inner_rgb[2]);
    (0..n * n)
        .map(|i| {
            let u = (i % n) as f32 / (n - 1) as f32 * 2.0 - 1.0;
            let v = (i / n) as f32 / (n - 1) as f32 * 2.0 - 1.0;
            let rr = (u * u + v * v).sqrt();
            let a = v.atan2(u) / std::f32::consts::TAU + 0.5; // 0..1 around
                                                              // Periodic in `a`: blend two noise samples one period apart.
            let per = |nz: &Noise2, k: f32, y: f32, oct: u32| {
                (1.0 - a) * nz.fbm(a * k, y, oct) + a * nz.fbm((a - 1.0) * k, y, oct)
            };
            // Radial stroma fibres at two scales: thin streaks, broader bands.
            let fine = per(&fib, 150.0, rr * 5.0, 2);
            let fibres = per(&fib, 70.0, rr * 2.5, 3);
            let coarse = per(&fib2, 16.0, rr * 1.2, 3);
            let col_r = st.collarette_frac * (1.0 + 0.12 * per(&fib2, 9.0, 0.5, 2));
            let zone = smoothstep(col_r - 0.06, col_r + 0.06, rr + 0.05 * fibres);
            let mut c = inner.lerp(outer, zone);
            let streak = 0.35 * fine + 0.45 * fibres + 0.3 * coarse;
            c = c * (1.0 + st.fibre_contrast * 1.2 * streak);
            // Brighter fibre crests catch light (trabeculae).
            let crest = smoothstep(0.25, 0.6, fibres) * (1.0 - zone * 0.3);
            c = c + f3(0.035, 0.03, 0.022) * (crest * st.fibre_contrast);
            // Collarette: a raised, lighter, ragged ridge.
            let ring = (-((rr - col_r) / 0.03).powi(2)).exp();
            c = c * (1.0 + 0.25 * ring * (0.6 + 0.4 * fibres));
            // Crypts: radially elongated dark pits near the collarette.
            for &(ca, cr, sz) in &crypts {
                let mut da = (a - ca).abs();
                da = da.min(1.0 - da) * std::f32::consts::TAU * rr.max(0.1);
                let dr = (rr - cr) * 0.5;
                let q = (da * da + dr * dr) / (sz * sz);
                c = c * (1.0 - 0.5 * (-q).exp());
            }
            // Stroma thins and darkens toward the rim.
            c = c * (1.0 - 0.25 * smoothstep(0.6, 0.85, rr));
            // Limbal ring and the darker, shadowed rim.
            let limb = smoothstep(0.8, 0.98, rr) * st.limbal_darkness;
            c = c * (1.0 - limb);
            f3(c.x.max(0.0), c.y.max(0.0), c.z.max(0.0))
        })
        .collect()
}

/// Sclera: warm white, pinker toward the back, with thin red vessels that
/// thicken away from the cornea.
fn sclera_texture(id: &Identity) -> Vec<F3> {
    let n = SCLERA_TEX;
    let vein = Noise2::new(id.seed ^ 0x5C7E);
    let vein2 = Noise2::new(id.seed ^ 0x5C7F);
    let tint = Noise2::new(id.seed ^ 0x5C80);
    let limb = (id.eye.iris_radius_mm / id.eye.eyeball_radius_mm) as f32;
    (0..n * n)
        .map(|i| {
            let u = ((i % n) as f32 + 0.5) / n as f32 * 2.0 - 1.0;
            let v = ((i / n) as f32 + 0.5) / n as f32 * 2.0 - 1.0;
            let r = (u * u + v * v).sqrt();
            let base = f3(0.80, 0.74, 0.67);
            let pink = f3(0.72, 0.50, 0.44);
            let mut c = base.lerp(pink, smoothstep(0.7, 1.0, r) * 0.6);
            c = c * (1.0 + 0.03 * tint.fbm(u * 6.0, v * 6.0, 3));
            let density = smoothstep(limb + 0.08, 0.9, r);
            // Vessels: zero crossings of smooth noise give long thin lines.
            let a = (vein.fbm(u * 2.5, v * 2.5, 2)).abs();
            let b = (vein2.fbm(u * 5.0 + 3.0, v * 5.0, 2)).abs();
            let vessel = smoothstep(0.03, 0.0, a) * 0.35 + smoothstep(0.02, 0.0, b) * 0.2;
            c = c.lerp(f3(0.55, 0.12, 0.10), (vessel * density).min(0.85));
            // Bluish-grey ring at the limbus.
            let lr = (-((r - limb - 0.02) / 0.04).powi(2)).exp();
            c.lerp(f3(0.45, 0.47, 0.5), lr * 0.35)
        })
        .collect()
}

/// BT.709 limited-range RGB -> YUV, fixed point (16 fractional bits).
#[inline(always)]
fn yuv_of(r: i32, g: i32, b: i32) -> (u8, i32, i32) {
    let y = (11966 * r + 40254 * g + 4064 * b + (16 << 16) + 32768) >> 16;
    let u = -6596 * r - 22189 * g + 28785 * b;
    let v = 28785 * r - 26145 * g - 2639 * b;
    (y.clamp(0, 255) as u8, u, v)
}

#[inline(always)]
fn chroma(sum4: i32) -> u8 {
    ((sum4 + (128 << 18) + (1 << 17)) >> 18).clamp(0, 255) as u8
}

/// Converts a region of a full-frame RGB image into yuv420p planes.
pub fn rgb_to_yuv420(
    rgb: &[u8],
    stride_px: usize,
    region: [usize; 4],
    yuv: &mut [u8],
    w: usize,
    h: usize,
) {
    let [x0, y0, x1, y1] = region;
    let (yp, rest) = yuv.split_at_mut(w * h);
    let (up, vp) = rest.split_at_mut((w / 2) * (h / 2));
    for cy in y0 / 2..y1 / 2 {
        for cx in x0 / 2..x1 / 2 {
            let (mut su, mut sv) = (0, 0);
            for (dy, dx) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
                let (x, y) = (cx * 2 + dx, cy * 2 + dy);
                let i = (y * stride_px + x) * 3;
                let (yy, u, v) = yuv_of(rgb[i] as i32, rgb[i + 1] as i32, rgb[i + 2] as i32);
                yp[y * w + x] = yy;
                su += u;
                sv += v;
            }
            up[cy * (w / 2) + cx] = chroma(su);
            vp[cy * (w / 2) + cx] = chroma(sv);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The per-pixel bound that skips the cornea ray tracer must never skip
    /// a pixel where the cornea is actually hit, at any pose the gaze solver
    /// can produce, for either eye and several identities.
    #[test]
    fn cornea_bound_contains_every_cornea_pixel() {
        for seed in [0, 3, 9] {
            let id = if seed == 0 {
                Identity::reference()
            } else {
                Identity::sample(seed)
            };
            let scene = Scene::new(&id, 640, 360);
            for k in 0..2 {
                for (yaw, pitch) in [
                    (0.0, 0.0),
                    (YAW_LIMIT_RAD, 0.0),
                    (-YAW_LIMIT_RAD, PITCH_LIMIT_RAD),
                    (0.3, -PITCH_LIMIT_RAD),
                ] {
                    let pose = EyePose {
                        yaw_rad: yaw,
                        pitch_rad: pitch,
                    };
                    let ef = scene.eye_frame(k, pose, 0.0, 1.0);
                    let (mut hits, mut inside) = (0, 0);
                    for y in 0..ef.r.h {
                        for x in 0..ef.r.w {
                            let px = (ef.r.x0 + x) as f32 + 0.5;
                            let py = (ef.r.y0 + y) as f32 + 0.5;
                            let bound = may_meet_cornea(&ef, px, py);
                            inside += usize::from(bound);
                            if scene.shade_cornea(&ef, px, py).is_some() {
                                hits += 1;
                                assert!(bound, "seed {seed} eye {k} pose {pose:?} at ({px}, {py})");
                            }
                        }
                    }
                    assert!(
                        hits > 0,
                        "seed {seed} eye {k} pose {pose:?}: no cornea seen"
                    );
                    // Tight enough to be worth it: the skipped work is most
                    // of the box.
                    assert!(
                        inside < ef.r.w * ef.r.h / 2,
                        "{inside} of {}",
                        ef.r.w * ef.r.h
                    );
                }
            }
        }
    }
    #[test]
    fn bt709_white_black_and_red() {
        assert_eq!(yuv_of(255, 255, 255).0, 235);
        assert_eq!(yuv_of(0, 0, 0).0, 16);
        // Pure red: Y = 16 + 219 * 0.2126 = 62.6; Cr = 128 + 112 = 240.
        let (y, u, v) = yuv_of(255, 0, 0);
        assert_eq!(y, 63);
        assert_eq!(chroma(v * 4), 240);
        assert_eq!(chroma(u * 4), 102); // 128 - 112 * 0.2126 / 0.9278
    }
}
