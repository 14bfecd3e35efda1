//! Hair drawn as anti-aliased strands: each eye's upper and lower lash
//! textures, and the brows over the face background.
//!
//! Lashes and brows are the only thin, high-contrast structures in the
//! image; both are drawn once per session as alpha maps from seeded random
//! strands with [`draw_strand`], and only blended per pixel afterwards.

use super::eye_model::{EyeModel, LidState};
use super::{Scene, Side};
use crate::math::{smoothstep, v3};
use crate::rng::SplitMix64;

/// Lash texture rows below the lid margin (lash roots overlap the eye).
pub(super) const LASH_ROOT_PX: usize = 3;

/// Alpha below half an 8-bit step cannot change a pixel.
const ALPHA_EPS: f32 = 1.0 / 512.0;

impl Scene {
    /// Visible length of the upper lashes in the image, px.
    pub(super) fn lash_up_px(&self) -> f64 {
        // Lashes point toward the camera and curl; about half their length shows.
        self.identity.eye.lash_length_mm * 0.5 * self.px_per_mm
    }

    /// Draws upper and lower lashes into the lash textures of the eye on
    /// `side`, and records per column how far above and below the lid
    /// margins anything is drawn (the per-frame renderer skips the rest).
    pub(super) fn make_lashes(&mut self, side: Side) {
        let id = self.identity.clone();
        let sh = &id.eye;
        let r = self.eye(side);
        let w = r.w;
        let up_rows = (self.lash_up_px().ceil() as usize + LASH_ROOT_PX + 2).min(r.h);
        let lo_rows = ((self.lash_up_px() * 0.4).ceil() as usize + 2).min(r.h);
        let mut up = vec![0f32; w * up_rows];
        let mut lo = vec![0f32; w * lo_rows];
        let m = r.model.clone();
        let lashes = LashLayout {
            scene: self,
            open: m.lids(sh, 0.0, 0.0),
            model: &m,
            x0: r.x0 as f64,
            w,
            px_mm: self.px_per_mm,
            // Which image direction is "outer" for this eye.
            outer_dir: if m.side == Side::Left { -1.0 } else { 1.0 },
            lash_px: self.lash_up_px(),
        };
        let mut rng = SplitMix64::new(id.seed ^ (0x1A5 + side.index() as u64));
        lashes.lash_line(&mut up, up_rows);
        lashes.upper_lashes(&mut up, up_rows, &mut rng, sh.lash_count);
        lashes.lower_lashes(&mut lo, lo_rows, &mut rng, sh.lash_count / 3);
        // Alpha below half an 8-bit step cannot change a pixel: make it
        // exactly zero so those pixels are recognised as background.
        for a in up.iter_mut().chain(lo.iter_mut()) {
            if *a < ALPHA_EPS {
                *a = 0.0;
            }
        }
        let wl = 0.9 * self.px_per_mm as f32;
        let (up_reach, lo_reach) = lash_reach(&up, up_rows, &lo, lo_rows, w, wl);
        let e = self.eye_mut(side);
        e.up_reach = up_reach;
        e.lo_reach = lo_reach;
        e.lash_up = up;
        e.lash_up_rows = up_rows;
        e.lash_lo = lo;
        e.lash_lo_rows = lo_rows;
    }

    /// Brow hairs as an alpha map over the image.
    pub(super) fn brow_alpha(&self) -> Vec<f32> {
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
}

/// One eye's open upper lid and lash sizes, as the lash drawing needs them;
/// lash textures are in box columns and rows from the lid margin.
struct LashLayout<'a> {
    scene: &'a Scene,
    model: &'a EyeModel,
    open: LidState,
    /// Left edge of the eye box, image px.
    x0: f64,
    /// Box width, px (the textures' row length).
    w: usize,
    px_mm: f64,
    lash_px: f64,
    /// Image x direction (-1 or 1) of the eye's outer corner.
    outer_dir: f64,
}

impl LashLayout<'_> {
    /// Box column of the upper lid margin at `s` (0 inner corner, 1 outer).
    fn col_of(&self, s: f64) -> f64 {
        let p = self
            .scene
            .camera
            .project(self.model.lid_point(s, &self.open, true));
        p[0] - self.x0
    }

    /// The dense dark lash line along the upper margin, faded out at the
    /// corners.
    fn lash_line(&self, up: &mut [f32], up_rows: usize) {
        let (w, px_mm) = (self.w, self.px_mm);
        for x in 0..w {
            for row in 0..up_rows {
                let d = row as f64 - LASH_ROOT_PX as f64;
                let line = (-(d / (0.45 * px_mm)).powi(2)).exp() as f32 * 0.85;
                up[row * w + x] = line;
            }
        }
        // Fade the lash line out at the corners.
        let c0 = self.col_of(0.0);
        let c1 = self.col_of(1.0);
        let (ca, cb) = (c0.min(c1), c0.max(c1));
        for x in 0..w {
            let fx = x as f64;
            let fade = smoothstep(ca as f32, (ca + 0.12 * (cb - ca)) as f32, fx as f32)
                * smoothstep(cb as f32, (cb - 0.12 * (cb - ca)) as f32, fx as f32);
            for row in 0..up_rows {
                up[row * w + x] *= fade;
            }
        }
    }

    /// `count` upper lashes: long, curling outward, denser and longer toward
    /// the middle and outer third.
    fn upper_lashes(&self, up: &mut [f32], up_rows: usize, rng: &mut SplitMix64, count: u32) {
        let (lash_px, outer_dir) = (self.lash_px, self.outer_dir);
        for _ in 0..count {
            // Denser and longer toward the middle and outer third.
            let s = 0.06 + 0.92 * rng.f64().powf(0.85);
            let base_x = self.col_of(s) + rng.range(-1.0, 1.0);
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
                up,
                self.w,
                up_rows,
                &pts,
                0.16 * self.px_mm,
                rng.range(0.75, 1.0) as f32,
            );
        }
    }

    /// `count` lower lashes: short, fine and sparse, on the outer part of
    /// the lid (texture rows from the waterline down).
    fn lower_lashes(&self, lo: &mut [f32], lo_rows: usize, rng: &mut SplitMix64, count: u32) {
        let (lash_px, outer_dir) = (self.lash_px, self.outer_dir);
        for _ in 0..count {
            let s = 0.25 + 0.72 * rng.f64();
            let base_x = self.col_of(s) + rng.range(-1.0, 1.0);
            let len = lash_px * 0.35 * rng.range(0.6, 1.1);
            let lean = outer_dir * (0.1 + 0.5 * s) + rng.range(-0.2, 0.2);
            let pts: Vec<[f64; 2]> = (0..=5)
                .map(|j| {
                    let f = j as f64 / 5.0;
                    [base_x + len * f * lean * 0.6, len * f]
                })
                .collect();
            draw_strand(
                lo,
                self.w,
                lo_rows,
                &pts,
                0.07 * self.px_mm,
                rng.range(0.4, 0.8) as f32,
            );
        }
    }
}

/// Per box column, how far above the upper margin and below the lower one
/// (px) anything is drawn: the lashes' last visible texture row, or at
/// least the lash line and the waterline (`wl`, its width in px).
fn lash_reach(
    up: &[f32],
    up_rows: usize,
    lo: &[f32],
    lo_rows: usize,
    w: usize,
    wl: f32,
) -> (Vec<f32>, Vec<f32>) {
    let max_row = |tex: &[f32], rows: usize, x: usize| {
        (0..rows)
            .rev()
            .find(|&r| tex[r * w + x] > ALPHA_EPS)
            .map(|r| r as f32)
    };
    let up_reach = (0..w)
        .map(|x| max_row(up, up_rows, x).map_or(1.0, |r| (r - LASH_ROOT_PX as f32 + 2.0).max(1.0)))
        .collect();
    let lo_reach = (0..w)
        .map(|x| {
            let lash = max_row(lo, lo_rows, x).map_or(0.0, |r| wl * 0.6 + r + 2.0);
            lash.max(wl + 1.5)
        })
        .collect();
    (up_reach, lo_reach)
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
