//! The static face behind the eyes: skin over a shaped relief, lid creases,
//! fine lines, brows and lens vignetting, drawn once per session.
//!
//! Everything outside the two eye boxes never changes during a session, and
//! inside them the lids are drawn from this image, so it is rendered once
//! in linear RGB ([`Scene::background`]) and converted to sRGB and yuv420p.
//! Each layer it draws is its own function below, back to front.
//!
//! The face is the plane `z = FACE_PLANE_Z_MM` of the head frame; a height
//! field ([`face_height_mm`]) only bends its normals for shading (the face
//! is not ray traced).

use super::eye_model::{EyeModel, LidState};
use super::Scene;
use crate::identity::EyeShape;
use crate::math::{f3, smoothstep, v3, F3, V3};
use crate::rng::{Noise2, SplitMix64};
use rayon::prelude::*;

/// Depth of the face plane (head frame, z toward the camera): the skin
/// around the eyes.
const FACE_PLANE_Z_MM: f64 = 10.0;

/// Grid step, px, of the slowly varying fields ([`SlowFields`]).
const SLOW_STEP_PX: usize = 4;

/// A curve on the face plane, mm: points evenly spaced in x, as
/// [`curve_at`] looks them up.
type FaceCurve = Vec<(f64, f64)>;

impl Scene {
    /// The static face: skin with shading of the orbits, brows, lid creases
    /// and the eyeballs under the lids (seen when the lids close). Linear RGB.
    ///
    /// Per pixel, back to front: the relief's lighting ([`SlowFields`]),
    /// the skin's albedo ([`skin_albedo`]), lid creases and under-eye lines
    /// ([`crease_darkness`]), a faint sheen ([`skin_sheen`]), brow hairs
    /// ([`Scene::brow_alpha`]) and lens vignetting ([`vignette`]).
    pub(super) fn background(&self) -> Vec<F3> {
        let id = &self.identity;
        let (w, h) = (self.width, self.height);
        let pores = Noise2::new(id.seed ^ 0x9023);
        let skin = f3(id.skin_rgb[0], id.skin_rgb[1], id.skin_rgb[2]);
        let eyes = [&self.eyes[0].model, &self.eyes[1].model];
        let open: Vec<LidState> = eyes.iter().map(|m| m.lids(&id.eye, 0.0, 0.0)).collect();
        let slow = self.slow_fields();
        let coords: Vec<(f64, f64)> = (0..w * h)
            .into_par_iter()
            .map(|i| self.face_xy((i % w) as f64 + 0.5, (i / w) as f64 + 0.5))
            .collect();
        let light = self.light;
        let lrgb = self.light_rgb;
        let amb = self.ambient;
        let brow = self.brow_alpha();
        let hair = f3(id.hair_rgb[0], id.hair_rgb[1], id.hair_rgb[2]);
        let creases = crease_curves(&id.eye, &eyes, &open);
        let under_lines = under_eye_lines(id.seed, &eyes, &open);
        (0..w * h)
            .into_par_iter()
            .map(|i| {
                let (x, y) = coords[i];
                let (px, py) = (i % w, i / w);
                let [nx, ny, nz, mottle, red, peri] = slow.at(px, py);
                let n = v3(nx as f64, ny as f64, nz as f64).norm();
                let ndl = n.dot(light) as f32;
                let diffuse = ((ndl + 0.35) / 1.35).max(0.0);
                let (alb, pore) = skin_albedo(skin, &pores, x, y, [mottle, red, peri]);
                let crease = crease_darkness(&creases, &under_lines, x, y);
                let shade = lrgb * (diffuse * (1.0 - crease))
                    + f3(1.0, 1.0, 1.0) * (amb * (1.0 - 0.6 * crease));
                let mut col = alb.mulv(shade);
                col = col + lrgb * skin_sheen(n, light, pore);
                let b = brow[i];
                if b > 0.0 {
                    col = col.lerp(hair.mulv(shade) * 0.9, b);
                }
                col * vignette(px, py, w, h)
            })
            .collect()
    }

    /// Where the ray through image point (u, v) meets the face plane, head
    /// frame x and y in mm.
    fn face_xy(&self, u: f64, v: f64) -> (f64, f64) {
        let cam = self.camera;
        let d =
            cam.fwd + cam.right * ((u - cam.cx) / cam.f_px) + cam.down * ((v - cam.cy) / cam.f_px);
        let t = (FACE_PLANE_Z_MM - cam.pos.z) / d.z;
        let p = cam.pos + d * t;
        (p.x, p.y)
    }

    /// The slowly varying layers of the face (the relief's normals and the
    /// skin's mottling, redness and darker skin around the eyes) on a coarse
    /// grid: evaluating them per pixel dominated the set-up time.
    fn slow_fields(&self) -> SlowFields {
        let id = &self.identity;
        let sh = &id.eye;
        let noise = Noise2::new(id.seed ^ 0x5C1);
        let half_ipd = sh.ipd_mm / 2.0;
        const STEP: usize = SLOW_STEP_PX;
        let (gw, gh) = (self.width / STEP + 2, self.height / STEP + 2);
        let mm_per_px = 1.0 / self.px_per_mm;
        let dmm = STEP as f64 * mm_per_px;
        let grid = (0..gw * gh)
            .into_par_iter()
            .map(|i| {
                let (u, v) = (((i % gw) * STEP) as f64, ((i / gw) * STEP) as f64);
                let (x, y) = self.face_xy(u, v);
                let n = face_normal(sh, x, y, dmm);
                let [mottle, red, peri] = skin_tone(&noise, half_ipd, x, y);
                [n.x as f32, n.y as f32, n.z as f32, mottle, red, peri]
            })
            .collect();
        SlowFields { grid, gw }
    }
}

/// Per-grid-point fields `[nx, ny, nz, mottle, red, peri]` every
/// `SLOW_STEP_PX` px, read back bilinearly per pixel.
struct SlowFields {
    grid: Vec<[f32; 6]>,
    /// Grid points per row.
    gw: usize,
}

impl SlowFields {
    /// The fields at pixel (px, py), interpolated between grid points.
    fn at(&self, px: usize, py: usize) -> [f32; 6] {
        const STEP: usize = SLOW_STEP_PX;
        let (gx, gy) = (px / STEP, py / STEP);
        let (tx, ty) = (
            ((px % STEP) as f32 + 0.5) / STEP as f32,
            ((py % STEP) as f32 + 0.5) / STEP as f32,
        );
        let g = |dx: usize, dy: usize| &self.grid[(gy + dy) * self.gw + gx + dx];
        let mut f = [0f32; 6];
        for (k, v) in f.iter_mut().enumerate() {
            let top = g(0, 0)[k] + (g(1, 0)[k] - g(0, 0)[k]) * tx;
            let bot = g(0, 1)[k] + (g(1, 1)[k] - g(0, 1)[k]) * tx;
            *v = top + (bot - top) * ty;
        }
        f
    }
}

/// Relief layer: the face's height above its plane at (x, y) mm (orbit
/// hollows, the eyeballs under the lids, brow ridges, cheeks, nose bridge).
/// Only its normals are used, for shading.
fn face_height_mm(sh: &EyeShape, x: f64, y: f64) -> f64 {
    let half_ipd = sh.ipd_mm / 2.0;
    let er = sh.eyeball_radius_mm;
    let mut hgt = 0.0;
    for ex in [-half_ipd, half_ipd] {
        let dx = x - ex;
        // Orbit hollow, deepest just above the eye under the brow.
        hgt -= 5.0
            * (-(dx * dx / (2.0 * 16.0f64.powi(2)) + (y + 3.0).powi(2) / (2.0 * 11.0f64.powi(2))))
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
            * (-(dx * dx / (2.0 * 9.0f64.powi(2)) + (y - 8.5).powi(2) / (2.0 * 1.8f64.powi(2))))
                .exp();
    }
    // Nose bridge rising toward the tip.
    hgt +=
        9.0 * (-(x * x) / (2.0 * 7.5f64.powi(2))).exp() * smoothstep(-35.0, 30.0, y as f32) as f64;
    hgt
}

/// The relief's unit normal at (x, y) mm, from [`face_height_mm`] by central
/// differences `dmm` apart.
fn face_normal(sh: &EyeShape, x: f64, y: f64, dmm: f64) -> V3 {
    let hx = face_height_mm(sh, x + dmm, y) - face_height_mm(sh, x - dmm, y);
    let hy = face_height_mm(sh, x, y + dmm) - face_height_mm(sh, x, y - dmm);
    v3(-hx / (2.0 * dmm), -hy / (2.0 * dmm), 1.0).norm()
}

/// Slow skin-tone fields at (x, y) mm: `[mottle, red, peri]`, the mottling
/// and redness noise and how much of the darker skin around the eyes is
/// there (eye centres at `-+half_ipd`).
fn skin_tone(noise: &Noise2, half_ipd: f64, x: f64, y: f64) -> [f32; 3] {
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
    [mottle, red, peri]
}

/// Skin layer: the albedo at (x, y) mm from the identity's skin colour,
/// the slow tone fields `[mottle, red, peri]` ([`skin_tone`]) and fine
/// pores; also returns the pore depth, which dulls the sheen.
fn skin_albedo(skin: F3, pores: &Noise2, x: f64, y: f64, tone: [f32; 3]) -> (F3, f32) {
    let [mottle, red, peri] = tone;
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
    (alb, pore)
}

/// Crease layer: upper-lid crease curves, per eye, in mm, sampled densely
/// for a lookup by x: the open upper lid lifted by the identity's crease
/// height, most in the middle.
fn crease_curves(sh: &EyeShape, eyes: &[&EyeModel; 2], open: &[LidState]) -> Vec<FaceCurve> {
    eyes.iter()
        .zip(open)
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
        .collect()
}

/// Fine-line layer: two lines under each eye, curves following the lower
/// lid a few millimetres below it, each with a seeded depth and strength
/// (they fade out at their ends, see [`crease_darkness`]).
fn under_eye_lines(seed: u64, eyes: &[&EyeModel; 2], open: &[LidState]) -> Vec<(FaceCurve, f32)> {
    let mut wr = SplitMix64::new(seed ^ 0x3A1);
    eyes.iter()
        .zip(open)
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
        .collect()
}

/// How much the creases and under-eye lines darken (positive) or lighten
/// (negative) the skin at (x, y) mm, clamped to -0.3..0.8.
fn crease_darkness(creases: &[FaceCurve], under_lines: &[(FaceCurve, f32)], x: f64, y: f64) -> f32 {
    // Lid crease: a soft dark fold with a lighter lid below it.
    let mut crease = 0.0f32;
    for c in creases {
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
    for (c, strength) in under_lines {
        if let Some((sx, cy)) = curve_at(c, x) {
            let dy = (y - cy) as f32;
            if dy.abs() < 1.0 {
                let fade = (std::f32::consts::PI * sx).sin();
                // A thin dark fold with a faint lit edge below it.
                crease += strength
                    * fade
                    * ((-(dy / 0.13).powi(2)).exp() - 0.4 * (-((dy - 0.25) / 0.15).powi(2)).exp());
            }
        }
    }
    crease.clamp(-0.3, 0.8)
}

/// Sheen layer: a faint specular highlight on the skin (normal `n`, key
/// light `light`), dulled where pores are deep; times the light colour.
fn skin_sheen(n: V3, light: V3, pore: f32) -> f32 {
    let hv = (light + v3(0.0, 0.0, 1.0)).norm();
    (n.dot(hv).max(0.0) as f32).powi(24) * 0.035 * (1.0 - 0.6 * pore)
}

/// Lens layer: slight vignetting, the factor at pixel (px, py) of a w x h
/// image.
fn vignette(px: usize, py: usize, w: usize, h: usize) -> f32 {
    let vx = (px as f32 / w as f32 - 0.5) * 2.0;
    let vy = (py as f32 / h as f32 - 0.5) * 2.0;
    1.0 - 0.12 * (vx * vx + vy * vy) * 0.5
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
