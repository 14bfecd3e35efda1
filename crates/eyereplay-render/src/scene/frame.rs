//! Per-frame rendering of the two eye boxes: the per-eye set-up a frame
//! shares across its pixels ([`EyeFrame`]: rotation, projected lid curves,
//! colours), and writing shaded pixels over the background into yuv420p
//! (2x2 blocks, straight to the encoder's format) or RGB.
//!
//! Only the rows each column's lids and lashes can reach are shaded; the
//! rest of a box is copied from the background.

use super::eye_model::{LidState, CORNEA_RADIUS_MM};
use super::{EyePose, EyeRaster, Scene, Side};
use crate::encode::{chroma, yuv_of};
use crate::math::{f3, smoothstep, Basis, F3};
use rayon::prelude::*;

/// Eye dimensions in f32 for the per-pixel ray tracer (eye coordinates, mm).
pub(super) struct EyeGeoF32 {
    pub(super) radius: f32,
    pub(super) iris_r: f32,
    pub(super) limbus_z: f32,
    pub(super) cornea_z: f32,
    pub(super) cornea_r: f32,
    pub(super) iris_z: f32,
}

impl EyeGeoF32 {
    /// The eye model's dimensions in f32.
    pub(super) fn of(m: &super::eye_model::EyeModel) -> EyeGeoF32 {
        EyeGeoF32 {
            radius: m.radius_mm as f32,
            iris_r: m.iris_radius_mm as f32,
            limbus_z: m.limbus_z_mm as f32,
            cornea_z: m.cornea_centre_z_mm as f32,
            cornea_r: CORNEA_RADIUS_MM as f32,
            iris_z: m.iris_z_mm as f32,
        }
    }
}

/// Per-frame, per-eye values shared by all pixels.
pub(super) struct EyeFrame<'a> {
    pub(super) r: &'a EyeRaster,
    /// The camera and the ray basis of a pixel (`dir_fwd + dir_right * (px
    /// - cx) + dir_down * (py - cy)`) in the turned eye's frame, mm.
    pub(super) origin: F3,
    pub(super) dir_fwd: F3,
    pub(super) dir_right: F3,
    pub(super) dir_down: F3,
    /// Key light direction in the turned eye's frame.
    pub(super) light: F3,
    pub(super) cx: f32,
    pub(super) cy: f32,
    pub(super) geo: EyeGeoF32,
    pub(super) pupil_mm: f32,
    /// Per box column: image y of the upper and lower lid margins (1e6 and
    /// -1e6 where the eye is closed or outside its corners).
    pub(super) up: Vec<f32>,
    pub(super) lo: Vec<f32>,
    /// Per column: corner shading factor and caruncle blend, from the lid
    /// parameter s (0 inner corner .. 1 outer).
    pub(super) corner_col: Vec<(f32, f32)>,
    /// How far along a ray to jump before intersecting (keeps precision).
    pub(super) origin_skip_mm: f32,
    /// The eye's x and y axes in the head frame: a head-frame normal's
    /// sclera texture coordinates are its dot products with them.
    pub(super) axis_x: F3,
    pub(super) axis_y: F3,
    /// Head-frame ray of a pixel (unnormalized): `ray_fwd + ray_right * (px
    /// - cx) + ray_down * (py - cy)`.
    pub(super) ray_fwd: F3,
    pub(super) ray_right: F3,
    pub(super) ray_down: F3,
    /// From the camera to the centre of the sphere that bounds the corneal
    /// cap (limbus plane centre), head frame, and `|q|^2 - r_bound^2`: rays
    /// farther than `r_bound` from that centre cannot meet the cornea.
    pub(super) cap_q: F3,
    pub(super) cap_qq_minus_r2: f32,
    pub(super) waterline_px: f32,
    pub(super) inv_shadow_px: f32,
    pub(super) hair: F3,
    pub(super) wet: F3,
    pub(super) caruncle: F3,
}

impl Scene {
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
        for (side, pose) in Side::BOTH.into_iter().zip(poses) {
            let r = self.eye(side);
            if r.w == 0 || r.h == 0 {
                continue;
            }
            let ef = self.eye_frame(side, pose, closure, pupil_scale);
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
        for (side, pose) in Side::BOTH.into_iter().zip(poses) {
            let r = self.eye(side);
            if r.w == 0 || r.h == 0 {
                continue;
            }
            let ef = self.eye_frame(side, pose, closure, pupil_scale);
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

    /// What every pixel of the eye on `side` shares in one frame: the
    /// eye's rotation in f32, its lid curves per column, and colours.
    pub(super) fn eye_frame(
        &self,
        side: Side,
        pose: EyePose,
        closure: f64,
        pupil_scale: f64,
    ) -> EyeFrame<'_> {
        let r = self.eye(side);
        let m = &r.model;
        let rot = Basis::gaze(pose.yaw_rad, pose.pitch_rad);
        let lids = m.lids(&self.identity.eye, pose.pitch_rad, closure);
        let (up, lo, s_col) = self.lid_columns(r, &lids);
        let cam = &self.camera;
        let waterline_px = (0.9 * self.px_per_mm) as f32;
        let corner_col = self.corner_columns(&s_col, &up, &lo);
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
            geo: EyeGeoF32::of(m),
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

    /// The upper and lower lid margins of eye box `r` at every box column
    /// (image y, px; 1e6 / -1e6 where the eye is closed or outside the
    /// corners), and the upper lid's parameter s (0 inner corner .. 1 outer)
    /// there.
    fn lid_columns(&self, r: &EyeRaster, lids: &LidState) -> (Vec<f32>, Vec<f32>, Vec<f32>) {
        let m = &r.model;
        // Project the lid curves and resample them per image column.
        const N: usize = 96;
        let mut up_pts = Vec::with_capacity(N + 1);
        let mut lo_pts = Vec::with_capacity(N + 1);
        for i in 0..=N {
            let s = i as f64 / N as f64;
            up_pts.push((self.camera.project(m.lid_point(s, lids, true)), s));
            lo_pts.push((self.camera.project(m.lid_point(s, lids, false)), s));
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
        (up, lo, s_col)
    }

    /// Per column: the corner shading factor and the caruncle blend, from
    /// the lid parameter `s_col` and the lid gap `lo - up`.
    fn corner_columns(&self, s_col: &[f32], up: &[f32], lo: &[f32]) -> Vec<(f32, f32)> {
        // The eye darkens into both corners and into a narrow slit (the
        // lids shade it: no bright sclera line in a closing blink); the
        // pink caruncle fills the inner corner.
        s_col
            .iter()
            .zip(up.iter().zip(lo))
            .map(|(&s, (&u, &l))| {
                let slit = smoothstep(0.0, 0.6 * self.px_per_mm as f32, l - u);
                (
                    (0.55 + 0.45 * smoothstep(0.0, 0.22, s.min(1.0 - s))) * slit,
                    smoothstep(0.10, 0.02, s) * 0.85,
                )
            })
            .collect()
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
