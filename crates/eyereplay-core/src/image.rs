//! An owned 8-bit RGB image: the face renderer's frames and textures and
//! the replay mode's decoded carrier frames.

/// Packed 8-bit RGB, rows top to bottom.
#[derive(Clone, Debug, PartialEq)]
pub struct RgbImage {
    pub width: usize,
    pub height: usize,
    pub data: Vec<u8>,
}

impl RgbImage {
    pub fn filled(width: usize, height: usize, rgb: [u8; 3]) -> RgbImage {
        let mut data = Vec::with_capacity(width * height * 3);
        for _ in 0..width * height {
            data.extend_from_slice(&rgb);
        }
        RgbImage {
            width,
            height,
            data,
        }
    }

    /// The picture turned as EXIF orientation `o` says it is to be shown
    /// (the TIFF 6.0 convention: 6 turns it a quarter clockwise, 8 a
    /// quarter anticlockwise, 3 a half; 2 and 4 mirror it, 5 and 7
    /// mirror it across a diagonal).
    pub fn oriented(&self, o: u32) -> RgbImage {
        let (w, h) = (self.width, self.height);
        let swap = matches!(o, 5..=8);
        let (ow, oh) = if swap { (h, w) } else { (w, h) };
        let mut data = vec![0u8; self.data.len()];
        for y in 0..h {
            for x in 0..w {
                // Where the stored pixel (x, y) is shown.
                let (dx, dy) = match o {
                    2 => (w - 1 - x, y),
                    3 => (w - 1 - x, h - 1 - y),
                    4 => (x, h - 1 - y),
                    5 => (y, x),
                    6 => (h - 1 - y, x),
                    7 => (h - 1 - y, w - 1 - x),
                    8 => (y, w - 1 - x),
                    _ => (x, y),
                };
                let (src, dst) = (3 * (y * w + x), 3 * (dy * ow + dx));
                data[dst..dst + 3].copy_from_slice(&self.data[src..src + 3]);
            }
        }
        RgbImage {
            width: ow,
            height: oh,
            data,
        }
    }

    #[inline]
    pub fn pixel(&self, x: usize, y: usize) -> [u8; 3] {
        let i = (y * self.width + x) * 3;
        [self.data[i], self.data[i + 1], self.data[i + 2]]
    }

    #[inline]
    pub fn set(&mut self, x: usize, y: usize, c: [u8; 3]) {
        let i = (y * self.width + x) * 3;
        self.data[i..i + 3].copy_from_slice(&c);
    }

    /// Bilinear RGB at continuous pixel coordinates (pixel centres at
    /// +0.5), edges replicated.
    #[inline(always)]
    pub fn sample(&self, x: f32, y: f32) -> [f32; 3] {
        let (i, ax, ay) = self.bilinear_at(x, y);
        #[cfg(target_arch = "x86_64")]
        if i[3] + 4 <= self.data.len() {
            // SAFETY: i[3] is the largest offset, so every texel's 4-byte
            // read ends inside the data.
            return sse2::to_rgb(unsafe { sse2::bilinear(&self.data, i, ax, ay) });
        }
        self.bilinear_scalar(i, ax, ay)
    }

    /// [`RgbImage::sample`] rounded to bytes, as `(c + 0.5) as u8` per
    /// channel (the blend never leaves 0..=255).
    #[inline(always)]
    pub fn sample_rgb8(&self, x: f32, y: f32) -> [u8; 3] {
        let (i, ax, ay) = self.bilinear_at(x, y);
        #[cfg(target_arch = "x86_64")]
        if i[3] + 4 <= self.data.len() {
            // SAFETY: as in `sample`.
            return unsafe { sse2::to_rgb8(sse2::bilinear(&self.data, i, ax, ay)) };
        }
        self.bilinear_scalar(i, ax, ay).map(|c| (c + 0.5) as u8)
    }

    /// The byte offsets of the four texels around (x, y) (top left, top
    /// right, bottom left, bottom right; edges replicated) and the blend
    /// weights along x and y.
    #[inline(always)]
    fn bilinear_at(&self, x: f32, y: f32) -> ([usize; 4], f32, f32) {
        // Sizes fit i64, so the conversions are single instructions (an
        // unsigned 64-bit one is a branchy sequence); values unchanged.
        let fx = (x - 0.5).clamp(0.0, (self.width - 1) as i64 as f32);
        let fy = (y - 0.5).clamp(0.0, (self.height - 1) as i64 as f32);
        // Non-negative after the clamp, so truncation is floor (and NaN
        // gives 0, as before).
        let x0 = fx as i32 as usize;
        let y0 = fy as i32 as usize;
        let x1 = (x0 + 1).min(self.width - 1);
        let y1 = (y0 + 1).min(self.height - 1);
        let (ax, ay) = (fx - x0 as i32 as f32, fy - y0 as i32 as f32);
        let (r0, r1) = (y0 * self.width, y1 * self.width);
        (
            [(r0 + x0) * 3, (r0 + x1) * 3, (r1 + x0) * 3, (r1 + x1) * 3],
            ax,
            ay,
        )
    }

    /// The blend of [`RgbImage::bilinear_at`]'s texels, channel by channel.
    #[inline(always)]
    fn bilinear_scalar(&self, i: [usize; 4], ax: f32, ay: f32) -> [f32; 3] {
        // One bounds check per texel instead of one per channel.
        let texel = |i: usize| -> [u8; 3] {
            let t: &[u8; 3] = self.data[i..i + 3].try_into().expect("3 bytes");
            *t
        };
        let [t00, t01, t10, t11] = i.map(texel);
        let mut out = [0.0f32; 3];
        for (c, o) in out.iter_mut().enumerate() {
            let top = t00[c] as f32 + (t01[c] as f32 - t00[c] as f32) * ax;
            let bot = t10[c] as f32 + (t11[c] as f32 - t10[c] as f32) * ax;
            *o = top + (bot - top) * ay;
        }
        out
    }
}

/// [`RgbImage::sample`]'s blend with the three channels in one SSE2
/// vector (SSE2 is part of x86-64, so no run-time check). Per channel the
/// same operations in the same order as the scalar code, `a + (b - a) t`
/// with no fused multiply-add, so the same bits.
#[cfg(target_arch = "x86_64")]
mod sse2 {
    use std::arch::x86_64::*;

    /// The blend of the texels at byte offsets `i` (4 lanes: R, G, B and a
    /// don't-care, the next texel's first byte).
    ///
    /// # Safety
    /// Every `i[k] + 4 <= d.len()`.
    #[inline(always)]
    pub(super) unsafe fn bilinear(d: &[u8], i: [usize; 4], ax: f32, ay: f32) -> __m128 {
        let p = d.as_ptr();
        // SAFETY: the caller keeps every 4-byte read inside `d`;
        // read_unaligned allows any alignment.
        let word = |k: usize| unsafe { (p.add(i[k]) as *const i32).read_unaligned() };
        let zero = _mm_setzero_si128();
        // Two texels side by side as 8 bytes, widened to two vectors of
        // four f32 lanes.
        let lanes = |a: i32, b: i32| {
            let bytes = _mm_unpacklo_epi32(_mm_cvtsi32_si128(a), _mm_cvtsi32_si128(b));
            let words = _mm_unpacklo_epi8(bytes, zero);
            (
                _mm_cvtepi32_ps(_mm_unpacklo_epi16(words, zero)),
                _mm_cvtepi32_ps(_mm_unpackhi_epi16(words, zero)),
            )
        };
        let (t00, t01) = lanes(word(0), word(1));
        let (t10, t11) = lanes(word(2), word(3));
        let lerp = |a: __m128, b: __m128, t: __m128| _mm_add_ps(a, _mm_mul_ps(_mm_sub_ps(b, a), t));
        let (vx, vy) = (_mm_set1_ps(ax), _mm_set1_ps(ay));
        lerp(lerp(t00, t01, vx), lerp(t10, t11, vx), vy)
    }

    /// Lanes 0-2 of a blend.
    #[inline(always)]
    pub(super) fn to_rgb(v: __m128) -> [f32; 3] {
        let mut out = [0.0f32; 4];
        // SAFETY: SSE2 only (every x86-64 CPU has it); `out` holds 4 f32
        // and the store is unaligned.
        unsafe { _mm_storeu_ps(out.as_mut_ptr(), v) };
        [out[0], out[1], out[2]]
    }

    /// Lanes 0-2 of a blend (each within 0..=255) as `(c + 0.5) as u8`:
    /// truncation of a non-negative value is the cast's floor, and NaN
    /// gives 0 as the cast does.
    #[inline(always)]
    pub(super) fn to_rgb8(v: __m128) -> [u8; 3] {
        // SAFETY: SSE2 only, which every x86-64 CPU has.
        let word = unsafe {
            let i = _mm_cvttps_epi32(_mm_add_ps(v, _mm_set1_ps(0.5)));
            // Saturating packs, like the cast: negative to 0, past 255 to 255.
            _mm_cvtsi128_si32(_mm_packus_epi16(_mm_packs_epi32(i, i), _mm_setzero_si128()))
        };
        let [r, g, b, _] = word.to_le_bytes();
        [r, g, b]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each EXIF orientation against its definition (TIFF 6.0: where the
    /// stored picture's first row and column are shown), on a 3x2 picture
    /// whose pixels are numbered 1-6 in stored order:
    /// ```text
    /// 1 2 3
    /// 4 5 6
    /// ```
    #[test]
    fn exif_orientations_turn_the_picture_as_defined() {
        let stored = RgbImage {
            width: 3,
            height: 2,
            data: (1..=6u8).flat_map(|v| [v, v, v]).collect(),
        };
        let shown = |o: u32| {
            let r = stored.oriented(o);
            let rows: Vec<Vec<u8>> = (0..r.height)
                .map(|y| (0..r.width).map(|x| r.pixel(x, y)[0]).collect())
                .collect();
            rows
        };
        // 1: as stored; 2: mirrored left-right; 3: turned a half; 4:
        // mirrored top-bottom.
        assert_eq!(shown(1), [[1, 2, 3], [4, 5, 6]]);
        assert_eq!(shown(2), [[3, 2, 1], [6, 5, 4]]);
        assert_eq!(shown(3), [[6, 5, 4], [3, 2, 1]]);
        assert_eq!(shown(4), [[4, 5, 6], [1, 2, 3]]);
        // 6: the first stored row is the right column, read top down
        // (a quarter clockwise); 8: the left column, read bottom up.
        assert_eq!(shown(6), [[4, 1], [5, 2], [6, 3]]);
        assert_eq!(shown(8), [[3, 6], [2, 5], [1, 4]]);
        // 5: the transpose; 7: the transverse (the other diagonal).
        assert_eq!(shown(5), [[1, 4], [2, 5], [3, 6]]);
        assert_eq!(shown(7), [[6, 3], [5, 2], [4, 1]]);
    }

    /// The vector blend gives the scalar per-channel blend's bits (and its
    /// bytes the cast's), everywhere: inside, on the last row and column
    /// (where the scalar code runs, no byte after the last texel), past
    /// the edges, at exact texel centres and for NaN; and both match the
    /// formula worked by hand at one point.
    #[test]
    fn sample_matches_the_per_channel_blend() {
        let (w, h) = (7usize, 5usize);
        let mut img = RgbImage::filled(w, h, [0, 0, 0]);
        for (i, b) in img.data.iter_mut().enumerate() {
            *b = ((i * 97 + 13) % 256) as u8;
        }
        let mut points = vec![(f32::NAN, 2.0), (3.0, f32::NAN), (-4.0, 99.0)];
        for j in 0..=80 {
            for k in 0..=60 {
                points.push((j as f32 * 0.1 - 0.5, k as f32 * 0.1 - 0.5));
            }
        }
        for (x, y) in points {
            let (i, ax, ay) = img.bilinear_at(x, y);
            let want = img.bilinear_scalar(i, ax, ay);
            let got = img.sample(x, y);
            assert_eq!(got.map(f32::to_bits), want.map(f32::to_bits), "({x}, {y})");
            assert_eq!(
                img.sample_rgb8(x, y),
                want.map(|c| (c + 0.5) as u8),
                "({x}, {y})"
            );
        }
        // (2.25, 3.25) is three quarters of the way from texel centre
        // (1.5, 2.5) to (2.5, 3.5) along both axes: weights 1/4 * 1/4 for
        // texel (1, 2), 3/4 * 1/4 for (2, 2) and (1, 3), 3/4 * 3/4 for (2, 3).
        let t = |x: usize, y: usize, c: usize| img.data[(y * w + x) * 3 + c] as f64;
        let got = img.sample(2.25, 3.25);
        for (c, &g) in got.iter().enumerate() {
            let want = 0.0625 * t(1, 2, c)
                + 0.1875 * t(2, 2, c)
                + 0.1875 * t(1, 3, c)
                + 0.5625 * t(2, 3, c);
            assert!((g as f64 - want).abs() < 1e-4, "channel {c}: {g} vs {want}");
        }
    }
}
