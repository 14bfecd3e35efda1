//! RGB to yuv420p colour conversion, BT.709 limited range, in fixed point.
//!
//! It lives beside the encoder because yuv420p in BT.709 is what the x264
//! child is fed and what the MP4's colour tags declare; the renderer calls
//! [`yuv_of`] and [`chroma`] per 2x2 block so that the frames it writes
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
