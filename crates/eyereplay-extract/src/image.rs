//! A decoded frame as the models see it, and the crops cut from it.
//!
//! Crops are sampled straight from the decoder's planes (YUV 4:2:0 in the
//! common case) with bilinear interpolation: converting only the ~60k
//! pixels the models read is far cheaper than converting a whole 1080p
//! frame to RGB. Rotation metadata is folded into the same affine mapping,
//! so a rotated video costs no extra copy.

use crate::geom::{Pt, Roi};

/// How the stored picture must be turned to be shown upright, clockwise
/// (ffmpeg's display-matrix rotation, negated as `ffmpeg -autorotate` does).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Rotation {
    #[default]
    None,
    Cw90,
    Cw180,
    Cw270,
}

impl Rotation {
    /// From a display-matrix angle in degrees, counter-clockwise as
    /// `av_display_rotation_get` returns it; snapped to quarter turns.
    pub fn from_display_ccw_deg(ccw: f64) -> Rotation {
        let cw = (-ccw).rem_euclid(360.0);
        match ((cw / 90.0).round() as i64).rem_euclid(4) {
            1 => Rotation::Cw90,
            2 => Rotation::Cw180,
            3 => Rotation::Cw270,
            _ => Rotation::None,
        }
    }
}

/// YUV to RGB matrix (coefficients for V->R, U->G, V->G, U->B) and range.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct YuvMatrix {
    y_scale: f32,
    y_off: f32,
    vr: f32,
    ug: f32,
    vg: f32,
    ub: f32,
}

impl YuvMatrix {
    pub fn new(bt709: bool, full_range: bool) -> YuvMatrix {
        let (vr, ug, vg, ub) = if bt709 {
            (1.5748, 0.1873, 0.4681, 1.8556)
        } else {
            (1.402, 0.3441, 0.7141, 1.772)
        };
        if full_range {
            YuvMatrix {
                y_scale: 1.0,
                y_off: 0.0,
                vr,
                ug,
                vg,
                ub,
            }
        } else {
            // Limited range: Y in 16..235, chroma in 16..240.
            let c = 255.0 / 224.0;
            YuvMatrix {
                y_scale: 255.0 / 219.0,
                y_off: 16.0,
                vr: vr * c,
                ug: ug * c,
                vg: vg * c,
                ub: ub * c,
            }
        }
    }
    /// One pixel's RGB (0..255) from its Y, U and V bytes.
    #[inline]
    pub fn rgb(&self, y: f32, u: f32, v: f32) -> [f32; 3] {
        let y = (y - self.y_off) * self.y_scale;
        let u = u - 128.0;
        let v = v - 128.0;
        [
            (y + self.vr * v).clamp(0.0, 255.0),
            (y - self.ug * u - self.vg * v).clamp(0.0, 255.0),
            (y + self.ub * u).clamp(0.0, 255.0),
        ]
    }
}

/// Borrowed pixel planes of one frame.
#[derive(Clone, Copy, Debug)]
pub enum Planes<'a> {
    /// 8-bit 4:2:0 planar (yuv420p / yuvj420p): the decoders' usual output.
    Yuv420 {
        y: &'a [u8],
        u: &'a [u8],
        v: &'a [u8],
        y_stride: usize,
        c_stride: usize,
        matrix: YuvMatrix,
    },
    /// Packed RGB, 3 bytes a pixel (any other format is converted to this).
    Rgb24 { data: &'a [u8], stride: usize },
}

/// A frame: its planes at stored size plus the rotation that shows it upright.
/// All coordinates outside this module are upright ("display") pixels.
#[derive(Clone, Copy, Debug)]
pub struct ImageView<'a> {
    pub planes: Planes<'a>,
    /// Stored (coded) size.
    pub raw_w: usize,
    pub raw_h: usize,
    pub rotation: Rotation,
}

/// How many crop rows ahead a crop asks for the image's cache lines.
const PREFETCH_ROWS: f32 = 2.0;
/// Frames of more pixels than this get their crop reads prefetched
/// (640x480 and larger).
const PREFETCH_MIN_PX: usize = 300_000;

/// What a crop shows outside the image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Border {
    /// Repeat the edge pixel (MediaPipe's landmark models).
    Replicate,
    /// Black, i.e. RGB (0,0,0) (the detector's letterbox).
    Black,
}

impl<'a> ImageView<'a> {
    /// Upright width and height in pixels.
    pub fn size(&self) -> (usize, usize) {
        match self.rotation {
            Rotation::Cw90 | Rotation::Cw270 => (self.raw_h, self.raw_w),
            _ => (self.raw_w, self.raw_h),
        }
    }

    /// Upright continuous coordinates -> stored continuous coordinates, as
    /// the affine map `raw = o + X * ax + Y * ay`.
    fn display_to_raw(&self) -> ([f32; 2], [f32; 2], [f32; 2]) {
        let (w, h) = (self.raw_w as f32, self.raw_h as f32);
        match self.rotation {
            Rotation::None => ([0.0, 0.0], [1.0, 0.0], [0.0, 1.0]),
            // Shown turned clockwise: display X runs down the stored rows
            // from the bottom, display Y runs along stored x.
            Rotation::Cw90 => ([0.0, h], [0.0, -1.0], [1.0, 0.0]),
            Rotation::Cw180 => ([w, h], [-1.0, 0.0], [0.0, -1.0]),
            Rotation::Cw270 => ([w, 0.0], [0.0, 1.0], [-1.0, 0.0]),
        }
    }

    /// Bilinear RGB at stored continuous coordinates, edges replicated.
    #[inline(always)]
    fn sample_raw(&self, x: f32, y: f32) -> [f32; 3] {
        let (w, h) = (self.raw_w, self.raw_h);
        match self.planes {
            Planes::Yuv420 {
                y: yp,
                u,
                v,
                y_stride,
                c_stride,
                matrix,
            } => {
                let luma = bilinear(yp, y_stride, w, h, x - 0.5, y - 0.5);
                // Chroma: nearest sample of the half-resolution planes. Bilinear
                // chroma cost two thirds of the crop time, and the landmark
                // networks barely see the difference (checked against the
                // MediaPipe reference: same r to 3 decimals).
                let cxi = ((x.max(0.0) as usize) >> 1).min((w - 1) >> 1);
                let cyi = ((y.max(0.0) as usize) >> 1).min((h - 1) >> 1);
                let ci = cyi * c_stride + cxi;
                let (cu, cv) = (u[ci] as f32, v[ci] as f32);
                matrix.rgb(luma, cu, cv)
            }
            Planes::Rgb24 { data, stride } => bilinear_rgb(data, stride, w, h, x - 0.5, y - 0.5),
        }
    }

    /// Asks the CPU to start loading the cache lines that
    /// [`ImageView::sample_raw`] at stored coordinates (`x`, `y`) will read.
    /// A crop reads a sparse grid out of a frame the decoder has just
    /// written: on a 1080p frame most loads missed the caches, and the
    /// crops spent a third of their time waiting on the first byte.
    #[inline(always)]
    fn prefetch_raw(&self, x: f32, y: f32) {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
            // Saturating casts: any point outside the frame prefetches an
            // edge line, which is harmless (a prefetch never faults, and
            // only addresses inside the planes are formed).
            let xi = (x.max(0.0) as usize).min(self.raw_w - 1);
            let yi = (y.max(0.0) as usize).min(self.raw_h - 1);
            let line = |p: &[u8], i: usize| {
                let i = i.min(p.len() - 1);
                // SAFETY: `i` < p.len(), so the pointer is inside the slice;
                // prefetching has no other effect than on the caches.
                unsafe { _mm_prefetch::<_MM_HINT_T0>(p.as_ptr().add(i) as *const i8) };
            };
            match self.planes {
                Planes::Yuv420 {
                    y: yp,
                    u,
                    v,
                    y_stride,
                    c_stride,
                    ..
                } => {
                    line(yp, yi * y_stride + xi);
                    line(yp, (yi + 1) * y_stride + xi);
                    let ci = (yi >> 1) * c_stride + (xi >> 1);
                    line(u, ci);
                    line(v, ci);
                }
                Planes::Rgb24 { data, stride } => {
                    line(data, yi * stride + 3 * xi);
                    line(data, (yi + 1) * stride + 3 * xi);
                }
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = (x, y);
    }

    /// RGB at an upright continuous coordinate.
    pub fn sample(&self, p: Pt) -> [f32; 3] {
        let (o, ax, ay) = self.display_to_raw();
        self.sample_raw(
            o[0] + p.x * ax[0] + p.y * ay[0],
            o[1] + p.x * ax[1] + p.y * ay[1],
        )
    }

    /// Cuts `roi` into a `size` x `size` planar RGB tensor (NCHW, one image):
    /// `out[c][row][col] = rgb * scale + offset`. With `mirror` the crop is
    /// flipped left-right (MediaPipe feeds the second eye to the iris model
    /// mirrored, since the model was trained on one side).
    #[allow(clippy::too_many_arguments)]
    pub fn crop_nchw(
        &self,
        roi: &Roi,
        size: usize,
        mirror: bool,
        border: Border,
        scale: f32,
        offset: f32,
        out: &mut [f32],
    ) {
        assert_eq!(out.len(), 3 * size * size);
        let g = CropGeometry::new(self, roi, size, mirror, scale, offset);
        if let Planes::Yuv420 {
            y: yp,
            u,
            v,
            y_stride,
            c_stride,
            matrix,
        } = self.planes
        {
            if border == Border::Replicate {
                let yuv = Yuv420Ref {
                    y: yp,
                    u,
                    v,
                    y_stride,
                    c_stride,
                    w: self.raw_w,
                    h: self.raw_h,
                };
                self.crop_yuv420(&yuv, matrix, &g, out);
                return;
            }
        }
        let (dw, dh) = self.size();
        let (dw, dh) = (dw as f32, dh as f32);
        let plane = size * size;
        let black = offset; // rgb 0 after scaling
        for row in 0..size {
            for col in 0..size {
                let c = if mirror { size - 1 - col } else { col };
                let x = g.p00.x + c as f32 * g.du.x + row as f32 * g.dv.x;
                let y = g.p00.y + c as f32 * g.du.y + row as f32 * g.dv.y;
                let i = row * size + col;
                if border == Border::Black && (x < 0.0 || y < 0.0 || x >= dw || y >= dh) {
                    out[i] = black;
                    out[plane + i] = black;
                    out[2 * plane + i] = black;
                    continue;
                }
                let (rx, ry) = g.raw(x, y);
                if g.prefetch {
                    g.prefetch_below(self, x, y);
                }
                let rgb = self.sample_raw(rx, ry);
                out[i] = rgb[0] * scale + offset;
                out[plane + i] = rgb[1] * scale + offset;
                out[2 * plane + i] = rgb[2] * scale + offset;
            }
        }
    }

    /// The face and eye crops of an 8-bit 4:2:0 frame
    /// ([`ImageView::crop_nchw`] with [`Border::Replicate`]).
    fn crop_yuv420(&self, yuv: &Yuv420Ref, matrix: YuvMatrix, g: &CropGeometry, out: &mut [f32]) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU has AVX-512F, checked above.
            unsafe { self.crop_yuv420_avx512(yuv, matrix, g, out) }
        } else {
            // SAFETY: SSE2 is part of every x86_64 CPU.
            unsafe { self.crop_yuv420_sse2(yuv, matrix, g, out) }
        }
        #[cfg(not(target_arch = "x86_64"))]
        self.crop_yuv420_lanes(yuv, matrix, g, out)
    }

    /// [`ImageView::crop_yuv420`] four crop pixels a step in SSE2 registers:
    /// the same IEEE operations per pixel, in the same order, as
    /// [`ImageView::sample_raw`] and [`ImageView::crop_yuv420_lanes`], so the
    /// same values bit for bit (the test
    /// `sse2_crop_matches_the_per_pixel_path_bit_for_bit`). The portable
    /// version stored each lane's coordinates and bytes one at a time to the
    /// stack and read them back as vectors, and every such read waited on
    /// the stores (`perf annotate`: a fifth of the crop's time on three
    /// loads); here the lanes are put together in registers, and the two
    /// luma bytes side by side are one 16-bit load.
    #[cfg(target_arch = "x86_64")]
    unsafe fn crop_yuv420_sse2(
        &self,
        yuv: &Yuv420Ref,
        matrix: YuvMatrix,
        g: &CropGeometry,
        out: &mut [f32],
    ) {
        use std::arch::x86_64::*;
        let (p00, du, dv, o, ax, ay) = (g.p00, g.du, g.dv, g.o, g.ax, g.ay);
        let (size, mirror) = (g.size, g.mirror);
        let plane = size * size;
        let splat = |v: f32| _mm_set1_ps(v);
        let (p00x, p00y, dux, duy) = (splat(p00.x), splat(p00.y), splat(du.x), splat(du.y));
        let (o0, o1) = (splat(o[0]), splat(o[1]));
        let (ax0, ax1, ay0, ay1) = (splat(ax[0]), splat(ax[1]), splat(ay[0]), splat(ay[1]));
        let half = splat(0.5);
        let zero = _mm_setzero_ps();
        let (wl, hl) = (splat((yuv.w - 1) as f32), splat((yuv.h - 1) as f32));
        let (y_off, y_scale) = (splat(matrix.y_off), splat(matrix.y_scale));
        let (c128, c255) = (splat(128.0), splat(255.0));
        let (vr, ug, vg, ub) = (
            splat(matrix.vr),
            splat(matrix.ug),
            splat(matrix.vg),
            splat(matrix.ub),
        );
        let (vscale, voffset) = (splat(g.scale), splat(g.offset));
        let byte = _mm_set1_epi32(0xff);
        let lane = _mm_setr_epi32(0, 1, 2, 3);
        for row in 0..size {
            let rowf = row as f32;
            let (rdx, rdy) = (splat(rowf * dv.x), splat(rowf * dv.y));
            for col0 in (0..size).step_by(4) {
                let n = 4.min(size - col0);
                // Crop columns (the last step's missing lanes repeat the
                // last column), mirrored or not, as floats.
                let cols = _mm_add_epi32(_mm_set1_epi32(col0 as i32), lane);
                let last = _mm_set1_epi32(size as i32 - 1);
                let over = _mm_cmpgt_epi32(cols, last);
                let cols = _mm_or_si128(_mm_and_si128(over, last), _mm_andnot_si128(over, cols));
                let cols = if mirror {
                    _mm_sub_epi32(last, cols)
                } else {
                    cols
                };
                let cf = _mm_cvtepi32_ps(cols);
                // x = p00.x + c du.x + row dv.x, then the stored coordinates.
                let x = _mm_add_ps(_mm_add_ps(p00x, _mm_mul_ps(cf, dux)), rdx);
                let y = _mm_add_ps(_mm_add_ps(p00y, _mm_mul_ps(cf, duy)), rdy);
                let rx = _mm_add_ps(_mm_add_ps(o0, _mm_mul_ps(x, ax0)), _mm_mul_ps(y, ay0));
                let ry = _mm_add_ps(_mm_add_ps(o1, _mm_mul_ps(x, ax1)), _mm_mul_ps(y, ay1));
                if g.prefetch {
                    // The step's first and last pixel, some rows down.
                    let (mut xs, mut ysv) = ([0f32; 4], [0f32; 4]);
                    _mm_storeu_ps(xs.as_mut_ptr(), x);
                    _mm_storeu_ps(ysv.as_mut_ptr(), y);
                    for k in [0, 3] {
                        g.prefetch_below(self, xs[k], ysv[k]);
                    }
                }
                let lx = _mm_sub_ps(rx, half);
                let ly = _mm_sub_ps(ry, half);
                // Every comparison is false for NaN.
                let inside = _mm_and_ps(
                    _mm_and_ps(_mm_cmpge_ps(lx, zero), _mm_cmpge_ps(ly, zero)),
                    _mm_and_ps(_mm_cmplt_ps(lx, wl), _mm_cmplt_ps(ly, hl)),
                );
                let (r, gch, b);
                if _mm_movemask_ps(inside) == 0xf {
                    // 0 <= lx < w - 1 and 0 <= ly < h - 1: truncation is
                    // the floor, and every index below is inside its plane.
                    let x0 = _mm_cvttps_epi32(lx);
                    let y0 = _mm_cvttps_epi32(ly);
                    let fx = _mm_sub_ps(lx, _mm_cvtepi32_ps(x0));
                    let fy = _mm_sub_ps(ly, _mm_cvtepi32_ps(y0));
                    let cx = _mm_srli_epi32(_mm_cvttps_epi32(rx), 1);
                    let cy = _mm_srli_epi32(_mm_cvttps_epi32(ry), 1);
                    let mut idx = [[0i32; 4]; 4];
                    _mm_storeu_si128(idx[0].as_mut_ptr() as *mut __m128i, x0);
                    _mm_storeu_si128(idx[1].as_mut_ptr() as *mut __m128i, y0);
                    _mm_storeu_si128(idx[2].as_mut_ptr() as *mut __m128i, cx);
                    _mm_storeu_si128(idx[3].as_mut_ptr() as *mut __m128i, cy);
                    let (l0, c0) = yuv.words(idx, 0);
                    let (l1, c1) = yuv.words(idx, 1);
                    let (l2, c2) = yuv.words(idx, 2);
                    let (l3, c3) = yuv.words(idx, 3);
                    let lw = _mm_setr_epi32(l0, l1, l2, l3);
                    let cw = _mm_setr_epi32(c0, c1, c2, c3);
                    let q0 = _mm_cvtepi32_ps(_mm_and_si128(lw, byte));
                    let q1 = _mm_cvtepi32_ps(_mm_and_si128(_mm_srli_epi32(lw, 8), byte));
                    let q2 = _mm_cvtepi32_ps(_mm_and_si128(_mm_srli_epi32(lw, 16), byte));
                    let q3 = _mm_cvtepi32_ps(_mm_srli_epi32(lw, 24));
                    let cu = _mm_cvtepi32_ps(_mm_and_si128(cw, byte));
                    let cv = _mm_cvtepi32_ps(_mm_srli_epi32(cw, 8));
                    let a = _mm_add_ps(q0, _mm_mul_ps(_mm_sub_ps(q1, q0), fx));
                    let bb = _mm_add_ps(q2, _mm_mul_ps(_mm_sub_ps(q3, q2), fx));
                    let luma = _mm_add_ps(a, _mm_mul_ps(_mm_sub_ps(bb, a), fy));
                    // YuvMatrix::rgb; max(0, .) then min(255, .) is clamp
                    // for finite values, -0.0 included.
                    let yv = _mm_mul_ps(_mm_sub_ps(luma, y_off), y_scale);
                    let u = _mm_sub_ps(cu, c128);
                    let v = _mm_sub_ps(cv, c128);
                    let clamp = |t: __m128| _mm_min_ps(c255, _mm_max_ps(zero, t));
                    r = clamp(_mm_add_ps(yv, _mm_mul_ps(vr, v)));
                    gch = clamp(_mm_sub_ps(
                        _mm_sub_ps(yv, _mm_mul_ps(ug, u)),
                        _mm_mul_ps(vg, v),
                    ));
                    b = clamp(_mm_add_ps(yv, _mm_mul_ps(ub, u)));
                } else {
                    // A lane outside: every lane by the general path, which
                    // replicates the edges.
                    let (mut xs, mut ysv) = ([0f32; 4], [0f32; 4]);
                    _mm_storeu_ps(xs.as_mut_ptr(), rx);
                    _mm_storeu_ps(ysv.as_mut_ptr(), ry);
                    let mut c = [[0f32; 4]; 3];
                    for k in 0..4 {
                        let p = self.sample_raw(xs[k], ysv[k]);
                        (c[0][k], c[1][k], c[2][k]) = (p[0], p[1], p[2]);
                    }
                    r = _mm_loadu_ps(c[0].as_ptr());
                    gch = _mm_loadu_ps(c[1].as_ptr());
                    b = _mm_loadu_ps(c[2].as_ptr());
                }
                let at = row * size + col0;
                for (ch, val) in [r, gch, b].into_iter().enumerate() {
                    let val = _mm_add_ps(_mm_mul_ps(val, vscale), voffset);
                    let dst = &mut out[ch * plane + at..ch * plane + at + n];
                    if n == 4 {
                        _mm_storeu_ps(dst.as_mut_ptr(), val);
                    } else {
                        let mut t = [0f32; 4];
                        _mm_storeu_ps(t.as_mut_ptr(), val);
                        dst.copy_from_slice(&t[..n]);
                    }
                }
            }
        }
    }

    /// [`ImageView::crop_yuv420`] sixteen crop pixels a step in AVX-512
    /// registers, its bytes fetched by gathers: the SSE2 version's IEEE
    /// operations per pixel in the same order, so the same values bit for
    /// bit (`sse2_crop_matches_the_per_pixel_path_bit_for_bit` compares
    /// the three). Where the SSE2 version puts each lane's bytes together
    /// from scalar loads, one gather per plane row fetches sixteen lanes'
    /// bytes; the crops take half the CPU time (the face crop was a
    /// seventh of extraction's at 360x288: EXTRACTION.md, "Where
    /// extraction's CPU time goes").
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    unsafe fn crop_yuv420_avx512(
        &self,
        yuv: &Yuv420Ref,
        matrix: YuvMatrix,
        g: &CropGeometry,
        out: &mut [f32],
    ) {
        use std::arch::x86_64::*;
        const LANES: usize = 16;
        let (p00, du, dv, o, ax, ay) = (g.p00, g.du, g.dv, g.o, g.ax, g.ay);
        let (size, mirror) = (g.size, g.mirror);
        let plane = size * size;
        let splat = |v: f32| _mm512_set1_ps(v);
        let (p00x, p00y, dux, duy) = (splat(p00.x), splat(p00.y), splat(du.x), splat(du.y));
        let (o0, o1) = (splat(o[0]), splat(o[1]));
        let (ax0, ax1, ay0, ay1) = (splat(ax[0]), splat(ax[1]), splat(ay[0]), splat(ay[1]));
        let half = splat(0.5);
        let zero = _mm512_setzero_ps();
        let (wl, hl) = (splat((yuv.w - 1) as f32), splat((yuv.h - 1) as f32));
        let (y_off, y_scale) = (splat(matrix.y_off), splat(matrix.y_scale));
        let (c128, c255) = (splat(128.0), splat(255.0));
        let (vr, ug, vg, ub) = (
            splat(matrix.vr),
            splat(matrix.ug),
            splat(matrix.vg),
            splat(matrix.ub),
        );
        let (vscale, voffset) = (splat(g.scale), splat(g.offset));
        let byte = _mm512_set1_epi32(0xff);
        let lane = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
        let last = _mm512_set1_epi32(size as i32 - 1);
        let (ys, cs) = (
            _mm512_set1_epi32(yuv.y_stride as i32),
            _mm512_set1_epi32(yuv.c_stride as i32),
        );
        // A gather reads four bytes from each lane's offset, of which the
        // lane uses one or two: a step whose last offset lies within three
        // bytes of a plane's end reads its bytes one lane at a time.
        let y_room = yuv.y.len().saturating_sub(3) as i32;
        let c_room = yuv.u.len().min(yuv.v.len()).saturating_sub(3) as i32;
        for row in 0..size {
            let rowf = row as f32;
            let (rdx, rdy) = (splat(rowf * dv.x), splat(rowf * dv.y));
            for col0 in (0..size).step_by(LANES) {
                let n = LANES.min(size - col0);
                // Crop columns (the last step's missing lanes repeat the
                // last column), mirrored or not, as floats.
                let cols =
                    _mm512_min_epi32(_mm512_add_epi32(_mm512_set1_epi32(col0 as i32), lane), last);
                let cols = if mirror {
                    _mm512_sub_epi32(last, cols)
                } else {
                    cols
                };
                let cf = _mm512_cvtepi32_ps(cols);
                // x = p00.x + c du.x + row dv.x, then the stored coordinates.
                let x = _mm512_add_ps(_mm512_add_ps(p00x, _mm512_mul_ps(cf, dux)), rdx);
                let y = _mm512_add_ps(_mm512_add_ps(p00y, _mm512_mul_ps(cf, duy)), rdy);
                let rx = _mm512_add_ps(
                    _mm512_add_ps(o0, _mm512_mul_ps(x, ax0)),
                    _mm512_mul_ps(y, ay0),
                );
                let ry = _mm512_add_ps(
                    _mm512_add_ps(o1, _mm512_mul_ps(x, ax1)),
                    _mm512_mul_ps(y, ay1),
                );
                if g.prefetch {
                    // The step's first and last pixel, some rows down
                    // (asking for two pixels of every four, as often as
                    // the SSE2 version asks, made the crops of a 1080p
                    // frame three times slower than the SSE2 version's).
                    let (mut xs, mut ysv) = ([0f32; LANES], [0f32; LANES]);
                    _mm512_storeu_ps(xs.as_mut_ptr(), x);
                    _mm512_storeu_ps(ysv.as_mut_ptr(), y);
                    for k in [0, 15] {
                        g.prefetch_below(self, xs[k], ysv[k]);
                    }
                }
                let lx = _mm512_sub_ps(rx, half);
                let ly = _mm512_sub_ps(ry, half);
                // Every ordered comparison is false for NaN.
                let inside = _mm512_cmp_ps_mask::<_CMP_GE_OQ>(lx, zero)
                    & _mm512_cmp_ps_mask::<_CMP_GE_OQ>(ly, zero)
                    & _mm512_cmp_ps_mask::<_CMP_LT_OQ>(lx, wl)
                    & _mm512_cmp_ps_mask::<_CMP_LT_OQ>(ly, hl);
                let mut gathered = None;
                if inside == 0xffff {
                    // 0 <= lx < w - 1 and 0 <= ly < h - 1: truncation is
                    // the floor, and every index below is inside its plane.
                    let x0 = _mm512_cvttps_epi32(lx);
                    let y0 = _mm512_cvttps_epi32(ly);
                    let cx = _mm512_srli_epi32::<1>(_mm512_cvttps_epi32(rx));
                    let cy = _mm512_srli_epi32::<1>(_mm512_cvttps_epi32(ry));
                    let top = _mm512_add_epi32(_mm512_mullo_epi32(y0, ys), x0);
                    let bot = _mm512_add_epi32(top, ys);
                    let ci = _mm512_add_epi32(_mm512_mullo_epi32(cy, cs), cx);
                    if _mm512_reduce_max_epi32(bot) < y_room && _mm512_reduce_max_epi32(ci) < c_room
                    {
                        let yp = yuv.y.as_ptr() as *const i32;
                        let t = _mm512_i32gather_epi32::<1>(top, yp);
                        let b = _mm512_i32gather_epi32::<1>(bot, yp);
                        let u = _mm512_i32gather_epi32::<1>(ci, yuv.u.as_ptr() as *const i32);
                        let v = _mm512_i32gather_epi32::<1>(ci, yuv.v.as_ptr() as *const i32);
                        gathered = Some((x0, y0, t, b, u, v));
                    }
                }
                let (r, gch, b);
                if let Some((x0, y0, t, bw, uw, vw)) = gathered {
                    let fx = _mm512_sub_ps(lx, _mm512_cvtepi32_ps(x0));
                    let fy = _mm512_sub_ps(ly, _mm512_cvtepi32_ps(y0));
                    let q0 = _mm512_cvtepi32_ps(_mm512_and_si512(t, byte));
                    let q1 = _mm512_cvtepi32_ps(_mm512_and_si512(_mm512_srli_epi32::<8>(t), byte));
                    let q2 = _mm512_cvtepi32_ps(_mm512_and_si512(bw, byte));
                    let q3 = _mm512_cvtepi32_ps(_mm512_and_si512(_mm512_srli_epi32::<8>(bw), byte));
                    let cu = _mm512_cvtepi32_ps(_mm512_and_si512(uw, byte));
                    let cv = _mm512_cvtepi32_ps(_mm512_and_si512(vw, byte));
                    let a = _mm512_add_ps(q0, _mm512_mul_ps(_mm512_sub_ps(q1, q0), fx));
                    let bb = _mm512_add_ps(q2, _mm512_mul_ps(_mm512_sub_ps(q3, q2), fx));
                    let luma = _mm512_add_ps(a, _mm512_mul_ps(_mm512_sub_ps(bb, a), fy));
                    // YuvMatrix::rgb; max(0, .) then min(255, .) as in the
                    // SSE2 version (minps/maxps return the second operand
                    // when either is NaN or both are zeros, and so do these).
                    let yv = _mm512_mul_ps(_mm512_sub_ps(luma, y_off), y_scale);
                    let u = _mm512_sub_ps(cu, c128);
                    let v = _mm512_sub_ps(cv, c128);
                    let clamp = |t: __m512| _mm512_min_ps(c255, _mm512_max_ps(zero, t));
                    r = clamp(_mm512_add_ps(yv, _mm512_mul_ps(vr, v)));
                    gch = clamp(_mm512_sub_ps(
                        _mm512_sub_ps(yv, _mm512_mul_ps(ug, u)),
                        _mm512_mul_ps(vg, v),
                    ));
                    b = clamp(_mm512_add_ps(yv, _mm512_mul_ps(ub, u)));
                } else {
                    // A lane outside, or a plane's end near: every lane by
                    // the general path, which replicates the edges.
                    let (mut xs, mut ysv) = ([0f32; LANES], [0f32; LANES]);
                    _mm512_storeu_ps(xs.as_mut_ptr(), rx);
                    _mm512_storeu_ps(ysv.as_mut_ptr(), ry);
                    let mut c = [[0f32; LANES]; 3];
                    for k in 0..LANES {
                        let p = self.sample_raw(xs[k], ysv[k]);
                        (c[0][k], c[1][k], c[2][k]) = (p[0], p[1], p[2]);
                    }
                    r = _mm512_loadu_ps(c[0].as_ptr());
                    gch = _mm512_loadu_ps(c[1].as_ptr());
                    b = _mm512_loadu_ps(c[2].as_ptr());
                }
                let at = row * size + col0;
                let keep: __mmask16 = if n == LANES { 0xffff } else { (1u16 << n) - 1 };
                for (ch, val) in [r, gch, b].into_iter().enumerate() {
                    let val = _mm512_add_ps(_mm512_mul_ps(val, vscale), voffset);
                    let dst = &mut out[ch * plane + at..ch * plane + at + n];
                    _mm512_mask_storeu_ps(dst.as_mut_ptr(), keep, val);
                }
            }
        }
    }

    /// [`ImageView::crop_yuv420`] in portable Rust, eight crop pixels a
    /// step (the reference for the SSE2 version, and the path elsewhere).
    #[cfg_attr(target_arch = "x86_64", allow(dead_code))]
    fn crop_yuv420_lanes(
        &self,
        yuv: &Yuv420Ref,
        matrix: YuvMatrix,
        g: &CropGeometry,
        out: &mut [f32],
    ) {
        let (p00, du, dv, o, ax, ay) = (g.p00, g.du, g.dv, g.o, g.ax, g.ay);
        let (size, mirror, scale, offset) = (g.size, g.mirror, g.scale, g.offset);
        let [o0, o1] = o;
        let plane = size * size;
        // LANES crop pixels at a time, each step over all lanes in
        // its own loop: the loads are per lane, the arithmetic
        // vectorizes (the same IEEE operations per pixel as the
        // general path, so the same values bit for bit).
        const LANES: usize = 8;
        for row in 0..size {
            let (r0, r1, r2) = {
                let (a, rest) = out[row * size..].split_at_mut(plane);
                let (b, c) = rest.split_at_mut(plane);
                (&mut a[..size], &mut b[..size], &mut c[..size])
            };
            for col0 in (0..size).step_by(LANES) {
                let n = LANES.min(size - col0);
                let (mut rx, mut ry) = ([0f32; LANES], [0f32; LANES]);
                for k in 0..LANES {
                    let col = (col0 + k).min(size - 1);
                    let c = if mirror { size - 1 - col } else { col };
                    let x = p00.x + c as f32 * du.x + row as f32 * dv.x;
                    let y = p00.y + c as f32 * du.y + row as f32 * dv.y;
                    rx[k] = o0 + x * ax[0] + y * ay[0];
                    ry[k] = o1 + x * ax[1] + y * ay[1];
                    if g.prefetch && (k == 0 || k == LANES - 1) {
                        // For the step's first and last pixel: the eight
                        // lie on one or two cache lines per image row.
                        g.prefetch_below(self, x, y);
                    }
                }
                let mut rgb = [[0f32; LANES]; 3];
                if let Some((luma, cu, cv)) = yuv.samples_inside(&rx, &ry) {
                    for k in 0..LANES {
                        let p = matrix.rgb(luma[k], cu[k], cv[k]);
                        (rgb[0][k], rgb[1][k], rgb[2][k]) = (p[0], p[1], p[2]);
                    }
                } else {
                    for k in 0..n {
                        let p = self.sample_raw(rx[k], ry[k]);
                        (rgb[0][k], rgb[1][k], rgb[2][k]) = (p[0], p[1], p[2]);
                    }
                }
                for (line, ch) in [&mut *r0, &mut *r1, &mut *r2].into_iter().zip(&rgb) {
                    for (o, &val) in line[col0..col0 + n].iter_mut().zip(ch) {
                        *o = val * scale + offset;
                    }
                }
            }
        }
    }

    /// [`ImageView::crop_nchw`] with each crop pixel the mean of `n` x `n`
    /// bilinear samples spread evenly over its footprint (a box filter).
    /// When the crop shrinks the image many times (a 280-px eye into the
    /// iris model's 64-px crop of 2.3 eye widths is 10 image px per crop
    /// px), one bilinear sample per crop pixel reads 4 of those 100 pixels:
    /// lashes and the limbus alias, and the crop's content jitters with the
    /// iris's sub-pixel position. `n` = 1 is exactly `crop_nchw` (Replicate
    /// border).
    #[allow(clippy::too_many_arguments)]
    pub fn crop_nchw_area(
        &self,
        roi: &Roi,
        size: usize,
        n: usize,
        mirror: bool,
        scale: f32,
        offset: f32,
        out: &mut [f32],
    ) {
        assert_eq!(out.len(), 3 * size * size);
        let n = n.max(1);
        let plane = size * size;
        let inv = 1.0 / size as f32;
        let sub = inv / n as f32;
        // Sub-sample centres -> upright image: p = p00 + i * du + j * dv,
        // with i, j counting sub-samples across the whole crop.
        let p00 = roi.to_image(0.5 * sub, 0.5 * sub);
        let p10 = roi.to_image(1.5 * sub, 0.5 * sub);
        let p01 = roi.to_image(0.5 * sub, 1.5 * sub);
        let du = Pt::new(p10.x - p00.x, p10.y - p00.y);
        let dv = Pt::new(p01.x - p00.x, p01.y - p00.y);
        let (o, ax, ay) = self.display_to_raw();
        let norm = scale / (n * n) as f32;
        for row in 0..size {
            for col in 0..size {
                let c = if mirror { size - 1 - col } else { col };
                let mut acc = [0.0f32; 3];
                for j in row * n..(row + 1) * n {
                    for i in c * n..(c + 1) * n {
                        let x = p00.x + i as f32 * du.x + j as f32 * dv.x;
                        let y = p00.y + i as f32 * du.y + j as f32 * dv.y;
                        let rgb = self
                            .sample_raw(o[0] + x * ax[0] + y * ay[0], o[1] + x * ax[1] + y * ay[1]);
                        acc[0] += rgb[0];
                        acc[1] += rgb[1];
                        acc[2] += rgb[2];
                    }
                }
                let k = row * size + col;
                out[k] = acc[0] * norm + offset;
                out[plane + k] = acc[1] * norm + offset;
                out[2 * plane + k] = acc[2] * norm + offset;
            }
        }
    }

    /// The whole frame upright as packed RGB bytes, enlarged `zoom` times
    /// (for previews of small videos).
    pub fn to_rgb8(&self, zoom: usize) -> (usize, usize, Vec<u8>) {
        let (w, h) = self.size();
        let (w, h) = (w * zoom, h * zoom);
        let z = zoom as f32;
        let mut out = Vec::with_capacity(w * h * 3);
        for y in 0..h {
            for x in 0..w {
                let rgb = self.sample(Pt::new((x as f32 + 0.5) / z, (y as f32 + 0.5) / z));
                out.extend(rgb.iter().map(|v| v.round() as u8));
            }
        }
        (w, h, out)
    }
}

/// Bilinear sample of one 8-bit plane at pixel-index coordinates (pixel
/// centres at integers), clamped to the plane (edge replicate). The inner
/// case (all four neighbours inside) is the hot path: two 2-byte slices,
/// no clamping.
#[inline(always)]
fn bilinear(p: &[u8], stride: usize, w: usize, h: usize, x: f32, y: f32) -> f32 {
    // Range check in floats, then a plain truncating conversion: Rust's
    // saturating `as usize` cast costs ~10 instructions per call, which
    // dominated the crops. Truncation equals floor for x, y >= 0.
    if x >= 0.0 && y >= 0.0 && x < (w - 1) as f32 && y < (h - 1) as f32 {
        // SAFETY: 0 <= x < w - 1 and 0 <= y < h - 1 (checked just above; NaN
        // fails the checks), so both fit in u32 and the cast is exact-truncating.
        let (x0, y0) = unsafe {
            (
                x.to_int_unchecked::<u32>() as usize,
                y.to_int_unchecked::<u32>() as usize,
            )
        };
        let fx = x - x0 as f32;
        let fy = y - y0 as f32;
        let i = y0 * stride + x0;
        let r0 = &p[i..i + 2];
        let r1 = &p[i + stride..i + stride + 2];
        let a = r0[0] as f32 + (r0[1] as f32 - r0[0] as f32) * fx;
        let b = r1[0] as f32 + (r1[1] as f32 - r1[0] as f32) * fx;
        return a + (b - a) * fy;
    }
    let x = x.clamp(0.0, (w - 1) as f32);
    let y = y.clamp(0.0, (h - 1) as f32);
    let x0 = x as usize;
    let y0 = y as usize;
    let x1 = (x0 + 1).min(w - 1);
    let y1 = (y0 + 1).min(h - 1);
    let fx = x - x0 as f32;
    let fy = y - y0 as f32;
    let r0 = y0 * stride;
    let r1 = y1 * stride;
    let a = p[r0 + x0] as f32 + (p[r0 + x1] as f32 - p[r0 + x0] as f32) * fx;
    let b = p[r1 + x0] as f32 + (p[r1 + x1] as f32 - p[r1 + x0] as f32) * fx;
    a + (b - a) * fy
}

/// Where a crop's pixels lie and how their values are scaled
/// ([`ImageView::crop_nchw`]).
#[derive(Clone, Copy)]
struct CropGeometry {
    /// Crop pixel (0, 0) in the upright image, and the steps per column
    /// and per row.
    p00: Pt,
    du: Pt,
    dv: Pt,
    /// Upright -> stored coordinates ([`ImageView::display_to_raw`]).
    o: [f32; 2],
    ax: [f32; 2],
    ay: [f32; 2],
    size: usize,
    mirror: bool,
    scale: f32,
    offset: f32,
    /// Ask for the image lines of later crop rows ahead (large frames).
    prefetch: bool,
}

impl CropGeometry {
    /// `roi` of `img` cut into `size` x `size` pixels.
    fn new(
        img: &ImageView,
        roi: &Roi,
        size: usize,
        mirror: bool,
        scale: f32,
        offset: f32,
    ) -> CropGeometry {
        let inv = 1.0 / size as f32;
        // Crop pixel centres -> upright image: p = p00 + col * du + row * dv.
        let p00 = roi.to_image(0.5 * inv, 0.5 * inv);
        let p10 = roi.to_image(1.5 * inv, 0.5 * inv);
        let p01 = roi.to_image(0.5 * inv, 1.5 * inv);
        let (o, ax, ay) = img.display_to_raw();
        CropGeometry {
            p00,
            du: Pt::new(p10.x - p00.x, p10.y - p00.y),
            dv: Pt::new(p01.x - p00.x, p01.y - p00.y),
            o,
            ax,
            ay,
            size,
            mirror,
            scale,
            offset,
            // A frame whose luma fits the core's cache gains nothing from
            // prefetching (360x288: the same CPU time or 1-2 % more), a
            // 720p or 1080p one does (the crops 1.8x faster at 1080p).
            prefetch: img.raw_w * img.raw_h > PREFETCH_MIN_PX,
        }
    }

    /// Upright (`x`, `y`) in stored coordinates.
    #[inline(always)]
    fn raw(&self, x: f32, y: f32) -> (f32, f32) {
        let (o, ax, ay) = (self.o, self.ax, self.ay);
        (o[0] + x * ax[0] + y * ay[0], o[1] + x * ax[1] + y * ay[1])
    }

    /// Asks for the image lines that the crop pixel `PREFETCH_ROWS` rows
    /// below upright (`x`, `y`) will read.
    #[inline(always)]
    fn prefetch_below(&self, img: &ImageView, x: f32, y: f32) {
        let (rx, ry) = self.raw(x + PREFETCH_ROWS * self.dv.x, y + PREFETCH_ROWS * self.dv.y);
        img.prefetch_raw(rx, ry);
    }
}

/// The planes of an 8-bit 4:2:0 frame, for the crops' inner loop.
struct Yuv420Ref<'a> {
    y: &'a [u8],
    u: &'a [u8],
    v: &'a [u8],
    y_stride: usize,
    c_stride: usize,
    w: usize,
    h: usize,
}

impl Yuv420Ref<'_> {
    /// Lane `k`'s bytes for the SSE2 crop, from its luma column and row and
    /// its chroma column and row (`idx[0..4]`): the 2 x 2 luma bytes as one
    /// word (the top pair in the low half), and u | v << 8.
    #[inline(always)]
    fn words(&self, idx: [[i32; 4]; 4], k: usize) -> (i32, i32) {
        let ys = self.y_stride;
        let i = idx[1][k] as usize * ys + idx[0][k] as usize;
        let top = u16::from_le_bytes([self.y[i], self.y[i + 1]]) as u32;
        let bot = u16::from_le_bytes([self.y[i + ys], self.y[i + ys + 1]]) as u32;
        let ci = idx[3][k] as usize * self.c_stride + idx[2][k] as usize;
        let uv = self.u[ci] as u32 | (self.v[ci] as u32) << 8;
        ((top | bot << 16) as i32, uv as i32)
    }

    /// What [`ImageView::sample_raw`] computes (bilinear luma, nearest
    /// chroma: luma, u, v), with the same arithmetic in the same order, at
    /// `N` points at once when all their luma pixels lie inside the frame;
    /// `None` otherwise (the caller takes the general path, which
    /// replicates the edges). Each step runs over all points in its own
    /// loop, so the arithmetic vectorizes and only the loads are per point:
    /// the crops took about 17 ns a pixel one point at a time (the 192-px
    /// face crop 0.63 ms of a 360x288 frame's 3.1 CPU-ms).
    #[inline(always)]
    fn samples_inside<const N: usize>(
        &self,
        x: &[f32; N],
        y: &[f32; N],
    ) -> Option<([f32; N], [f32; N], [f32; N])> {
        let (wl, hl) = ((self.w - 1) as f32, (self.h - 1) as f32);
        let (mut lx, mut ly) = ([0f32; N], [0f32; N]);
        let mut inside = true;
        for k in 0..N {
            lx[k] = x[k] - 0.5;
            ly[k] = y[k] - 0.5;
            // NaN fails every comparison.
            inside &= lx[k] >= 0.0 && ly[k] >= 0.0 && lx[k] < wl && ly[k] < hl;
        }
        if !inside {
            return None;
        }
        let (mut fx, mut fy) = ([0f32; N], [0f32; N]);
        let (mut at, mut ct) = ([0usize; N], [0usize; N]);
        for k in 0..N {
            // SAFETY: 0 <= lx < w - 1 and 0 <= ly < h - 1 (checked above),
            // so the truncating casts are exact floors that fit in u32; with
            // x = lx + 0.5 < w and y < h the chroma indices do too.
            let (x0, y0, cx, cy) = unsafe {
                (
                    lx[k].to_int_unchecked::<u32>(),
                    ly[k].to_int_unchecked::<u32>(),
                    x[k].to_int_unchecked::<u32>() >> 1,
                    y[k].to_int_unchecked::<u32>() >> 1,
                )
            };
            fx[k] = lx[k] - x0 as f32;
            fy[k] = ly[k] - y0 as f32;
            at[k] = y0 as usize * self.y_stride + x0 as usize;
            ct[k] = cy as usize * self.c_stride + cx as usize;
        }
        let mut q = [[0f32; N]; 4];
        let (mut cu, mut cv) = ([0f32; N], [0f32; N]);
        for k in 0..N {
            let i = at[k];
            // (x0, y0) and (x0 + 1, y0 + 1) are inside the frame, so
            // i + y_stride + 1 is inside the luma plane; ct[k] inside the
            // chroma planes. Checked indexing: the loads are not the cost.
            q[0][k] = self.y[i] as f32;
            q[1][k] = self.y[i + 1] as f32;
            q[2][k] = self.y[i + self.y_stride] as f32;
            q[3][k] = self.y[i + self.y_stride + 1] as f32;
            cu[k] = self.u[ct[k]] as f32;
            cv[k] = self.v[ct[k]] as f32;
        }
        let mut luma = [0f32; N];
        for k in 0..N {
            let a = q[0][k] + (q[1][k] - q[0][k]) * fx[k];
            let b = q[2][k] + (q[3][k] - q[2][k]) * fx[k];
            luma[k] = a + (b - a) * fy[k];
        }
        Some((luma, cu, cv))
    }
}

#[inline]
fn bilinear_rgb(p: &[u8], stride: usize, w: usize, h: usize, x: f32, y: f32) -> [f32; 3] {
    let x = x.clamp(0.0, (w - 1) as f32);
    let y = y.clamp(0.0, (h - 1) as f32);
    let x0 = x as usize;
    let y0 = y as usize;
    let x1 = (x0 + 1).min(w - 1);
    let y1 = (y0 + 1).min(h - 1);
    let fx = x - x0 as f32;
    let fy = y - y0 as f32;
    let mut out = [0.0; 3];
    for (c, o) in out.iter_mut().enumerate() {
        let g = |xx: usize, yy: usize| p[yy * stride + xx * 3 + c] as f32;
        let a = g(x0, y0) + (g(x1, y0) - g(x0, y0)) * fx;
        let b = g(x0, y1) + (g(x1, y1) - g(x0, y1)) * fx;
        *o = a + (b - a) * fy;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rgb_image(w: usize, h: usize) -> Vec<u8> {
        // Red encodes x, green encodes y: easy to check where a sample came from.
        let mut d = vec![0u8; w * h * 3];
        for y in 0..h {
            for x in 0..w {
                d[(y * w + x) * 3] = (x * 10) as u8;
                d[(y * w + x) * 3 + 1] = (y * 10) as u8;
            }
        }
        d
    }

    /// A tightly packed RGB24 image stored `w` x `h`, shown turned `rotation`.
    fn rgb_view(data: &[u8], w: usize, h: usize, rotation: Rotation) -> ImageView<'_> {
        ImageView {
            planes: Planes::Rgb24 {
                data,
                stride: w * 3,
            },
            raw_w: w,
            raw_h: h,
            rotation,
        }
    }

    #[test]
    fn rotation_90_shows_the_stored_left_column_at_the_top() {
        let (w, h) = (4, 3);
        let data = rgb_image(w, h);
        let img = rgb_view(&data, w, h, Rotation::Cw90);
        assert_eq!(img.size(), (3, 4));
        // Turned clockwise, the stored bottom-left pixel (x=0, y=2) is
        // shown at the top-left.
        let p = img.sample(Pt::new(0.5, 0.5));
        assert_eq!((p[0], p[1]), (0.0, 20.0));
        // Display bottom-left is the stored bottom-right... (x=3, y=2).
        let p = img.sample(Pt::new(0.5, 3.5));
        assert_eq!((p[0], p[1]), (30.0, 20.0));
        assert_eq!(Rotation::from_display_ccw_deg(-90.0), Rotation::Cw90);
        assert_eq!(Rotation::from_display_ccw_deg(90.0), Rotation::Cw270);
        assert_eq!(Rotation::from_display_ccw_deg(180.0), Rotation::Cw180);
    }

    #[test]
    fn identity_crop_reproduces_pixels_and_mirror_flips_them() {
        let (w, h) = (4, 4);
        let data = rgb_image(w, h);
        let img = rgb_view(&data, w, h, Rotation::None);
        let roi = Roi {
            cx: 2.0,
            cy: 2.0,
            w: 4.0,
            h: 4.0,
            angle_rad: 0.0,
        };
        let mut out = vec![0.0; 48];
        img.crop_nchw(&roi, 4, false, Border::Replicate, 1.0, 0.0, &mut out);
        assert_eq!(&out[0..4], &[0.0, 10.0, 20.0, 30.0]); // red row 0
        assert_eq!(out[16 + 4 * 3], 30.0); // green at row 3
        img.crop_nchw(&roi, 4, true, Border::Replicate, 1.0, 0.0, &mut out);
        assert_eq!(&out[0..4], &[30.0, 20.0, 10.0, 0.0]);
        // Letterbox: a crop twice as large is black (-1 after scaling) outside.
        let big = Roi {
            w: 8.0,
            h: 8.0,
            ..roi
        };
        img.crop_nchw(&big, 4, false, Border::Black, 1.0 / 127.5, -1.0, &mut out);
        assert_eq!(out[0], -1.0);
        assert!((out[5] - (5.0 / 127.5 - 1.0)).abs() < 1e-6, "{}", out[5]);
    }

    #[test]
    fn area_crop_averages_the_footprint_and_one_sample_is_the_plain_crop() {
        // Vertical stripes one pixel wide, 0 and 200 in red: a crop of 40 px
        // into 4 (10 px per crop pixel) should read their mean, 100, where a
        // single bilinear sample at a pixel centre reads 0 or 200.
        let (w, h) = (40, 40);
        let mut data = vec![0u8; w * h * 3];
        for y in 0..h {
            for x in (1..w).step_by(2) {
                data[(y * w + x) * 3] = 200;
            }
        }
        let img = rgb_view(&data, w, h, Rotation::None);
        let roi = Roi {
            cx: 20.5,
            cy: 20.0,
            w: 40.0,
            h: 40.0,
            angle_rad: 0.0,
        };
        let mut plain = vec![0.0; 48];
        img.crop_nchw(&roi, 4, false, Border::Replicate, 1.0, 0.0, &mut plain);
        // Crop pixel centres at x = 5.5, 15.5, ...: centres of odd columns.
        assert_eq!(plain[..4], [200.0; 4]);
        let mut area = vec![0.0; 48];
        // 4 sub-samples 2.5 px apart (x = 1.75, 4.25, 6.75, 9.25 in the
        // first crop pixel) read 150, 50, 50, 150.
        img.crop_nchw_area(&roi, 4, 4, false, 1.0, 0.0, &mut area);
        for v in &area[..16] {
            assert!((v - 100.0).abs() < 1e-3, "{v}");
        }
        img.crop_nchw_area(&roi, 4, 1, true, 1.0, 0.0, &mut area);
        let mut mirrored = vec![0.0; 48];
        img.crop_nchw(&roi, 4, true, Border::Replicate, 1.0, 0.0, &mut mirrored);
        assert_eq!(area, mirrored);
    }

    #[test]
    #[cfg(target_arch = "x86_64")]
    fn sse2_crop_matches_the_per_pixel_path_bit_for_bit() {
        // A textured 4:2:0 frame (odd width and height), cropped by
        // rotated, mirrored, scaled ROIs inside it and across its edges,
        // every rotation, both matrices, sizes with and without a partial
        // last step: the SSE2 path and, where the CPU has it, the AVX-512
        // one against the portable one, and against `sample_raw` pixel by
        // pixel. Once with padded strides, once unpadded, where the last
        // row's pixels end their planes: the AVX-512 path's gathers read
        // four bytes where a lane uses one or two, so a step within three
        // bytes of a plane's end must take the general path, and the
        // unpadded frame has such steps (counted).
        let padded = check_crop_paths(208, 104);
        let unpadded = check_crop_paths(CROP_W, CROP_W.div_ceil(2));
        assert!(padded.inside > 10_000, "{}", padded.inside);
        assert!(unpadded.inside > 10_000, "{}", unpadded.inside);
        assert_eq!(padded.at_plane_end, 0);
        assert!(unpadded.at_plane_end > 0, "no step reached the plane's end");
    }

    /// The crop test's frame: odd width and height.
    #[cfg(target_arch = "x86_64")]
    const CROP_W: usize = 203;
    #[cfg(target_arch = "x86_64")]
    const CROP_H: usize = 157;

    /// What [`check_crop_paths`] covered: crop pixels whose bilinear taps
    /// lie inside the frame, and 16-pixel steps wholly inside whose luma
    /// bytes end within three bytes of the plane's end.
    #[cfg(target_arch = "x86_64")]
    struct CropCoverage {
        inside: usize,
        at_plane_end: usize,
    }

    /// The crop paths compared bit for bit on a `CROP_W` x `CROP_H` frame
    /// with these strides (luma, chroma); see the test above.
    #[cfg(target_arch = "x86_64")]
    fn check_crop_paths(ys: usize, cs: usize) -> CropCoverage {
        let (w, h) = (CROP_W, CROP_H);
        let avx512 = std::arch::is_x86_feature_detected!("avx512f");
        let mut seed = 12345u32;
        let mut byte = || {
            seed = seed.wrapping_mul(1_103_515_245).wrapping_add(12345);
            (seed >> 16) as u8
        };
        let yp: Vec<u8> = (0..ys * h).map(|_| byte()).collect();
        let up: Vec<u8> = (0..cs * h.div_ceil(2)).map(|_| byte()).collect();
        let vp: Vec<u8> = (0..cs * h.div_ceil(2)).map(|_| byte()).collect();
        let yuv = Yuv420Ref {
            y: &yp,
            u: &up,
            v: &vp,
            y_stride: ys,
            c_stride: cs,
            w,
            h,
        };
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        let mut cover = CropCoverage {
            inside: 0,
            at_plane_end: 0,
        };
        let rotations = [
            Rotation::None,
            Rotation::Cw90,
            Rotation::Cw180,
            Rotation::Cw270,
        ];
        let rois = [
            (0.5, 0.5, 0.4, 0.0),
            (0.45, 0.55, 0.3, 0.37),
            (0.3, 0.6, 0.1, -1.2),
            (0.05, 0.9, 0.5, 0.8),
            (0.5, 0.5, 1.6, 3.0),
            // Near the stored frame's last pixels (upright: rotated).
            (0.975, 0.975, 0.04, 0.0),
        ];
        for (bt709, full) in [(false, false), (true, true)] {
            let matrix = YuvMatrix::new(bt709, full);
            for rotation in rotations {
                let img = ImageView {
                    planes: Planes::Yuv420 {
                        y: &yp,
                        u: &up,
                        v: &vp,
                        y_stride: ys,
                        c_stride: cs,
                        matrix,
                    },
                    raw_w: w,
                    raw_h: h,
                    rotation,
                };
                let (dw, dh) = img.size();
                let (dw, dh) = (dw as f32, dh as f32);
                for (k, &(cx, cy, side, angle)) in rois.iter().enumerate() {
                    let roi = Roi {
                        cx: cx * dw,
                        cy: cy * dh,
                        w: side * dw,
                        h: side * dw,
                        angle_rad: angle,
                    };
                    for (size, mirror) in [(64usize, false), (64, true), (30, false), (30, true)] {
                        let what = format!("{rotation:?} roi {k} size {size} stride {ys}");
                        let (scale, offset) = (1.0 / 127.5, -1.0);
                        let n = 3 * size * size;
                        let mut fast = vec![0f32; n];
                        img.crop_nchw(
                            &roi,
                            size,
                            mirror,
                            Border::Replicate,
                            scale,
                            offset,
                            &mut fast,
                        );
                        // The portable path through the same geometry,
                        // prefetching or not.
                        let g = CropGeometry {
                            prefetch: k % 2 == 1,
                            ..CropGeometry::new(&img, &roi, size, mirror, scale, offset)
                        };
                        let mut lanes = vec![0f32; n];
                        img.crop_yuv420_lanes(&yuv, matrix, &g, &mut lanes);
                        let mut sse2 = vec![0f32; n];
                        // SAFETY: SSE2 is part of every x86_64 CPU.
                        unsafe { img.crop_yuv420_sse2(&yuv, matrix, &g, &mut sse2) };
                        assert_eq!(bits(&fast), bits(&lanes), "{what}");
                        assert_eq!(bits(&sse2), bits(&lanes), "{what}");
                        if avx512 {
                            let mut wide = vec![0f32; n];
                            // SAFETY: the CPU has AVX-512F, checked above.
                            unsafe { img.crop_yuv420_avx512(&yuv, matrix, &g, &mut wide) };
                            assert_eq!(bits(&wide), bits(&lanes), "AVX-512: {what}");
                        }
                        // And pixel by pixel through sample_raw, each
                        // 16-pixel step's reach into the luma plane noted.
                        let (wl, hl) = ((w - 1) as f32, (h - 1) as f32);
                        for row in 0..size {
                            for col0 in (0..size).step_by(16) {
                                let (mut all_inside, mut last_byte) = (true, 0);
                                // The last step's missing lanes repeat the
                                // last column, as the AVX-512 path's do.
                                for lane in col0..col0 + 16 {
                                    let col = lane.min(size - 1);
                                    let c = if mirror { size - 1 - col } else { col };
                                    let x = g.p00.x + c as f32 * g.du.x + row as f32 * g.dv.x;
                                    let y = g.p00.y + c as f32 * g.du.y + row as f32 * g.dv.y;
                                    let (rx, ry) = g.raw(x, y);
                                    let (lx, ly) = (rx - 0.5, ry - 0.5);
                                    if lx >= 0.0 && ly >= 0.0 && lx < wl && ly < hl {
                                        let bottom = (ly as usize + 1) * ys + lx as usize;
                                        last_byte = last_byte.max(bottom + 3);
                                    } else {
                                        all_inside = false;
                                    }
                                    if lane >= size {
                                        continue;
                                    }
                                    if rx >= 0.5 && ry >= 0.5 && rx < w as f32 - 0.5 {
                                        cover.inside += 1;
                                    }
                                    let p = img.sample_raw(rx, ry);
                                    let i = row * size + col;
                                    for ch in 0..3 {
                                        let want = p[ch] * scale + offset;
                                        assert_eq!(
                                            sse2[ch * size * size + i].to_bits(),
                                            want.to_bits(),
                                            "{what} ({row}, {col})"
                                        );
                                    }
                                }
                                if all_inside && last_byte >= yp.len() {
                                    cover.at_plane_end += 1;
                                }
                            }
                        }
                    }
                }
            }
        }
        cover
    }

    #[test]
    fn yuv_grey_and_pure_colours_convert_like_bt601() {
        let m = YuvMatrix::new(false, false);
        let g = m.rgb(126.0, 128.0, 128.0);
        assert!((g[0] - 128.0).abs() < 0.6 && (g[1] - g[0]).abs() < 1e-4);
        // Limited-range BT.601 red is Y=81, U=90, V=240.
        let r = m.rgb(81.0, 90.0, 240.0);
        assert!(r[0] > 250.0 && r[1] < 3.0 && r[2] < 3.0, "{r:?}");
    }
}
