//! Per-pixel shading of an eye box: the eyeball (sclera, refracting cornea,
//! iris and pupil), the lid shadows, caruncle, waterline and lashes.
//!
//! This is the hot path: every function called per pixel is
//! `#[inline(always)]` (a call left in it cost a third of the render time).
//! What a pixel's shading needs per frame is prepared in
//! [`EyeFrame`]; what never changes as the eye turns
//! is prepared once per session in [`BallPx`] ([`Scene::make_ball`]).

use super::eye_model::CORNEA_INDEX;
use super::frame::{EyeFrame, EyeGeoF32};
use super::hair::LASH_ROOT_PX;
use super::textures::Textures;
use super::{Scene, Side};
use crate::math::{clamp01, f3, floor_fast, smoothstep, F3};

/// What does not change when the eye turns, for one pixel's ray.
///
/// The eyeball turns about its own centre, so the point where a pixel's
/// ray meets the sclera sphere, its normal, and the lighting there (key
/// light and camera are fixed in the head frame) are the same in every
/// frame; only which sclera texel lies at that point changes. Computing
/// them once per session leaves a rotation of `n` and a texture fetch per
/// sclera pixel, where the ray tracer spent most of a frame before.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct BallPx {
    /// Head frame, unit: the sclera normal where the ray hits the ball, or,
    /// where it passes beside it (toward the corners), the direction of
    /// the ray's closest approach to the centre.
    n: F3,
    /// Colour = sclera texel * `mul` + `add` (linear RGB).
    mul: F3,
    add: F3,
}

impl Scene {
    /// Fills the per-pixel [`BallPx`] of the eye on `side`: the sclera as
    /// the ray tracer would see it with the eye looking straight ahead, in
    /// the head frame.
    pub(super) fn make_ball(&mut self, side: Side) {
        let cam = self.camera;
        let r = self.eye(side);
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
        self.eye_mut(side).ball = ball;
    }

    /// Shades one pixel (box-relative) in linear RGB; `None` where it shows
    /// the background unchanged.
    #[inline(always)]
    pub(super) fn shade_px(&self, ef: &EyeFrame, x: usize, y: usize) -> Option<F3> {
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
        let tex = self.tex.sclera_at(b.n.dot(ef.axis_x), b.n.dot(ef.axis_y));
        tex.mulv(b.mul) + b.add
    }

    /// Ray-traces the cornea, the iris behind it and the limbus at image
    /// point (px, py); `None` where the ray does not meet the corneal cap.
    ///
    /// In f32: the ray starts 30 mm before the eye (so the quadratics do not
    /// lose precision to the 400+ mm camera distance), and single precision
    /// halves the latency of the square roots and divisions that dominate.
    #[inline(always)]
    pub(super) fn shade_cornea(&self, ef: &EyeFrame, px: f32, py: f32) -> Option<F3> {
        let d = ef.dir_fwd + ef.dir_right * (px - ef.cx) + ef.dir_down * (py - ef.cy);
        let d = d * (1.0 / d.dot(d).sqrt());
        let o = ef.origin + d * ef.origin_skip_mm;
        trace_cornea(
            &self.tex,
            self.light_rgb,
            self.ambient,
            &ef.geo,
            ef.pupil_mm,
            ef.light,
            o,
            d,
        )
    }

    /// [`sclera_light`] under the scene's light.
    #[inline(always)]
    fn sclera_light(&self, n: F3, d: F3, light: F3) -> (F3, F3) {
        sclera_light(self.light_rgb, self.ambient, n, d, light)
    }
}

/// Lighting of the sclera at unit normal `n` seen along `d` under a key
/// light of colour `light_rgb` from direction `light` plus `ambient`:
/// colour = texel * `mul` + `add`. Only dot products of `n`, `d` and
/// `light` enter, so any common frame works (eye frame per pixel at the
/// limbus, head frame once per session in [`BallPx`]).
#[inline(always)]
pub(super) fn sclera_light(light_rgb: F3, ambient: f32, n: F3, d: F3, light: F3) -> (F3, F3) {
    let ndl = n.dot(light);
    let ndv = -n.dot(d);
    let diffuse = ambient + 0.8 * ((ndl + 0.25) / 1.25).max(0.0);
    let rim = 0.45 + 0.55 * ndv.max(0.0);
    let refl = d + n * (2.0 * ndv);
    let spec = smoothstep(0.992, 0.998, refl.dot(light)) * 0.6;
    (
        (light_rgb * diffuse + f3(1.0, 1.0, 1.0) * (ambient * 0.3)) * rim,
        light_rgb * spec,
    )
}

/// Ray-traces the cornea, the iris behind it and the limbus for a ray from
/// `o` along unit `d` in the turned eye's frame (mm, origin at the eyeball
/// centre, +z out through the cornea), under a key light of colour
/// `light_rgb` from direction `light` (same frame) plus `ambient`; `None`
/// where the ray does not meet the corneal cap. Shared by the close-up
/// renderer and [`super::Eyeball`] (the full-face mode's eyes).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(super) fn trace_cornea(
    tex: &Textures,
    light_rgb: F3,
    ambient: f32,
    g: &EyeGeoF32,
    pupil_mm: f32,
    light: F3,
    o: F3,
    d: F3,
) -> Option<F3> {
    let lc = light_rgb;
    let amb = ambient;
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
    let pr = pupil_mm;
    let iris_light = amb + 0.75 * (0.4 + 0.6 * light.z.max(0.0));
    let mut col = if r2 < pr * pr {
        f3(0.006, 0.005, 0.005)
    } else if r2 < ri * ri {
        let tex = tex.iris_at(q.x / ri, q.y / ri);
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
        let n = on_ball * (1.0 / g.radius);
        let (mul, add) = sclera_light(light_rgb, ambient, n, d, light);
        col = (tex.sclera_at(n.x, n.y).mulv(mul) + add).lerp(col, edge);
    }
    // Corneal reflections: the key light's glint and a faint room.
    let refl = d + n * (2.0 * cosi);
    let glint = smoothstep(0.9965, 0.9985, refl.dot(light)) * 2.2;
    // A dim, even room reflection growing toward grazing angles.
    let fresnel = 0.02 + 0.2 * (1.0 - cosi).powi(4);
    let env = f3(0.5, 0.5, 0.55) * fresnel;
    Some(col + lc * glint + env)
}

/// Whether the ray of image point (px, py) passes within the sphere that
/// bounds the corneal cap: its squared distance from the sphere's centre,
/// `|q|^2 - (q.d)^2 / |d|^2`, below `r_bound^2`, without a root or division.
#[inline(always)]
pub(super) fn may_meet_cornea(ef: &EyeFrame, px: f32, py: f32) -> bool {
    let d = ef.ray_fwd + ef.ray_right * (px - ef.cx) + ef.ray_down * (py - ef.cy);
    let qd = ef.cap_q.dot(d);
    qd * qd > ef.cap_qq_minus_r2 * d.dot(d)
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

#[cfg(test)]
mod tests {
    use super::super::pose::{PITCH_LIMIT_RAD, YAW_LIMIT_RAD};
    use super::super::EyePose;
    use super::*;
    use crate::identity::Identity;

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
            for side in Side::BOTH {
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
                    let ef = scene.eye_frame(side, pose, 0.0, 1.0);
                    let (mut hits, mut inside) = (0, 0);
                    for y in 0..ef.r.h {
                        for x in 0..ef.r.w {
                            let px = (ef.r.x0 + x) as f32 + 0.5;
                            let py = (ef.r.y0 + y) as f32 + 0.5;
                            let bound = may_meet_cornea(&ef, px, py);
                            inside += usize::from(bound);
                            if scene.shade_cornea(&ef, px, py).is_some() {
                                hits += 1;
                                assert!(
                                    bound,
                                    "seed {seed} eye {side:?} pose {pose:?} at ({px}, {py})"
                                );
                            }
                        }
                    }
                    assert!(
                        hits > 0,
                        "seed {seed} eye {side:?} pose {pose:?}: no cornea seen"
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
}
