//! RGB to yuv420p colour conversion, BT.709 limited range, in fixed point.
//!
//! It lives beside the encoder because yuv420p in BT.709 is what the x264
//! child is fed and what the MP4's colour tags declare; the renderer calls
//! `yuv_of` and `chroma` per 2x2 block so that the frames it writes
//! straight into yuv420p match converting a full RGB frame with
//! [`rgb_to_yuv420`] byte for byte.

/// BT.709 limited-range RGB -> YUV, fixed point (16 fractional bits).
#[inline(always)]
pub(crate) fn yuv_of(r: i32, g: i32, b: i32) -> (u8, i32, i32) {
    let y = (11966 * r + 40254 * g + 4064 * b + (16 << 16) + 32768) >> 16;
    let u = -6596 * r - 22189 * g + 28785 * b;
    let v = 28785 * r - 26145 * g - 2639 * b;
    (y.clamp(0, 255) as u8, u, v)
}

/// A 2x2 block's chroma byte from the sum of its four fixed-point U (or V)
/// values from [`yuv_of`]: their average, offset by 128, rounded.
#[inline(always)]
pub(crate) fn chroma(sum4: i32) -> u8 {
    ((sum4 + (128 << 18) + (1 << 17)) >> 18).clamp(0, 255) as u8
}

/// Converts a region of a full-frame RGB image into yuv420p planes.
///
/// Two image rows at a time through row slices (no per-pixel index
/// arithmetic or bounds checks in the inner loop: at 1280x720 this was
/// 2-3 ms a frame the per-pixel way), 16 blocks a step
/// (built for AVX2 where the CPU has it); the arithmetic is `yuv_of`
/// and `chroma` per 2x2 block, so the bytes are the same.
pub fn rgb_to_yuv420(
    rgb: &[u8],
    stride_px: usize,
    region: [usize; 4],
    yuv: &mut [u8],
    w: usize,
    h: usize,
) {
    if region[2] / 2 <= region[0] / 2 {
        return;
    }
    let job = Conversion {
        rgb,
        stride_px,
        region,
        yuv,
        w,
        h,
    };
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU was just detected to support AVX2.
        unsafe { convert_avx2(job) };
        return;
    }
    convert_rows(job);
}

/// The arguments of one [`rgb_to_yuv420`] call.
struct Conversion<'a> {
    rgb: &'a [u8],
    stride_px: usize,
    region: [usize; 4],
    yuv: &'a mut [u8],
    w: usize,
    h: usize,
}

/// [`convert_rows`] compiled for AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn convert_avx2(job: Conversion) {
    convert_rows(job);
}

/// Chroma blocks converted per step of [`convert_rows`]: the channels are
/// first copied out of the interleaved RGB into arrays of this many pixel
/// pairs, so the arithmetic runs on whole vectors.
const BLOCKS_PER_STEP: usize = 16;

/// [`rgb_to_yuv420`]'s work, two image rows at a time.
#[inline(always)]
fn convert_rows(job: Conversion) {
    let Conversion {
        rgb,
        stride_px,
        region,
        yuv,
        w,
        h,
    } = job;
    let (yp, rest) = yuv.split_at_mut(w * h);
    let (up, vp) = rest.split_at_mut((w / 2) * (h / 2));
    const N: usize = BLOCKS_PER_STEP;
    let [x0, y0, x1, y1] = region;
    let (cx0, cx1) = (x0 / 2, x1 / 2);
    let cw = w / 2;
    for cy in y0 / 2..y1 / 2 {
        let (ya, yb) = (2 * cy, 2 * cy + 1);
        let src_a = &rgb[(ya * stride_px + 2 * cx0) * 3..(ya * stride_px + 2 * cx1) * 3];
        let src_b = &rgb[(yb * stride_px + 2 * cx0) * 3..(yb * stride_px + 2 * cx1) * 3];
        let (ly_a, ly_b) = yp[ya * w..(yb + 1) * w].split_at_mut(w);
        let ly_a = &mut ly_a[2 * cx0..2 * cx1];
        let ly_b = &mut ly_b[2 * cx0..2 * cx1];
        let u_row = &mut up[cy * cw + cx0..cy * cw + cx1];
        let v_row = &mut vp[cy * cw + cx0..cy * cw + cx1];
        // Whole steps of N blocks, then the rest block by block; the same
        // integer arithmetic either way, so the same bytes.
        let steps = (cx1 - cx0) / N;
        for s in 0..steps {
            let (pa, pb) = (&src_a[s * 6 * N..][..6 * N], &src_b[s * 6 * N..][..6 * N]);
            let mut ch = [[0i32; 2 * N]; 6];
            for i in 0..2 * N {
                for c in 0..3 {
                    ch[c][i] = pa[3 * i + c] as i32;
                    ch[3 + c][i] = pb[3 * i + c] as i32;
                }
            }
            let mut uv = [[0i32; 2 * N]; 4];
            let (ya, yb) = (
                &mut ly_a[s * 2 * N..][..2 * N],
                &mut ly_b[s * 2 * N..][..2 * N],
            );
            for i in 0..2 * N {
                let (y, u, v) = yuv_of(ch[0][i], ch[1][i], ch[2][i]);
                (ya[i], uv[0][i], uv[1][i]) = (y, u, v);
                let (y, u, v) = yuv_of(ch[3][i], ch[4][i], ch[5][i]);
                (yb[i], uv[2][i], uv[3][i]) = (y, u, v);
            }
            let (us, vs) = (&mut u_row[s * N..][..N], &mut v_row[s * N..][..N]);
            for j in 0..N {
                let (a, b) = (2 * j, 2 * j + 1);
                us[j] = chroma(uv[0][a] + uv[0][b] + uv[2][a] + uv[2][b]);
                vs[j] = chroma(uv[1][a] + uv[1][b] + uv[3][a] + uv[3][b]);
            }
        }
        let done = steps * N;
        let (src_a, src_b) = (&src_a[done * 6..], &src_b[done * 6..]);
        let (ly_a, ly_b) = (&mut ly_a[done * 2..], &mut ly_b[done * 2..]);
        let (u_row, v_row) = (&mut u_row[done..], &mut v_row[done..]);
        let blocks = src_a
            .chunks_exact(6)
            .zip(src_b.chunks_exact(6))
            .zip(ly_a.chunks_exact_mut(2).zip(ly_b.chunks_exact_mut(2)))
            .zip(u_row.iter_mut().zip(v_row.iter_mut()));
        for (((a, b), (oa, ob)), (u, v)) in blocks {
            let (y00, u00, v00) = yuv_of(a[0] as i32, a[1] as i32, a[2] as i32);
            let (y01, u01, v01) = yuv_of(a[3] as i32, a[4] as i32, a[5] as i32);
            let (y10, u10, v10) = yuv_of(b[0] as i32, b[1] as i32, b[2] as i32);
            let (y11, u11, v11) = yuv_of(b[3] as i32, b[4] as i32, b[5] as i32);
            oa[0] = y00;
            oa[1] = y01;
            ob[0] = y10;
            ob[1] = y11;
            *u = chroma(u00 + u01 + u10 + u11);
            *v = chroma(v00 + v01 + v10 + v11);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The per-pixel form the row form replaced: the reference.
    fn reference(
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

    #[test]
    fn rows_give_the_per_pixel_bytes() {
        // Pseudo-random pixels in a wider image; a whole frame and an
        // off-origin region (even bounds, as the callers pass).
        let (stride, w, h) = (70usize, 64usize, 40usize);
        let rgb: Vec<u8> = (0..stride * h * 3)
            .map(|i| ((i as u64).wrapping_mul(2654435761) >> 7) as u8)
            .collect();
        for region in [[0, 0, w, h], [6, 4, 40, 30]] {
            let mut a = vec![7u8; w * h * 3 / 2];
            let mut b = a.clone();
            rgb_to_yuv420(&rgb, stride, region, &mut a, w, h);
            reference(&rgb, stride, region, &mut b, w, h);
            assert_eq!(a, b, "{region:?}");
            // The build without AVX2 too, which an AVX2 machine never
            // picks.
            let mut c = vec![7u8; w * h * 3 / 2];
            convert_rows(Conversion {
                rgb: &rgb,
                stride_px: stride,
                region,
                yuv: &mut c,
                w,
                h,
            });
            assert_eq!(c, b, "{region:?} without AVX2");
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
