//! Times the 192x192 face crop alone on a synthetic 360x288 YUV frame
//! (N=repetitions, default 500): the crops were a fifth of the CPU per
//! frame before their hot path was tightened, so keep an eye on them.
use eyereplay_extract::*;
use std::time::Instant;
fn main() {
    let (w, h) = (360usize, 288usize);
    let y: Vec<u8> = (0..w * h).map(|i| (i % 251) as u8).collect();
    let u: Vec<u8> = (0..w * h / 4).map(|i| (i % 241) as u8).collect();
    let v = u.clone();
    let img = ImageView {
        planes: Planes::Yuv420 {
            y: &y,
            u: &u,
            v: &v,
            y_stride: w,
            c_stride: w / 2,
            matrix: YuvMatrix::new(false, false),
        },
        raw_w: w,
        raw_h: h,
        rotation: Rotation::None,
    };
    let roi = Roi {
        cx: 190.0,
        cy: 150.0,
        w: 220.0,
        h: 220.0,
        angle_rad: 0.1,
    };
    let mut out = vec![0f32; 3 * 192 * 192];
    let n: usize = std::env::var("N")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(500);
    let t = Instant::now();
    for _ in 0..n {
        img.crop_nchw(
            &roi,
            192,
            false,
            Border::Replicate,
            1.0 / 255.0,
            0.0,
            &mut out,
        );
    }
    let dt = t.elapsed().as_secs_f64() / n as f64;
    println!(
        "192x192 crop: {:.3} ms = {:.1} ns/pixel (checksum {})",
        dt * 1e3,
        dt * 1e9 / (192.0 * 192.0),
        out[1000]
    );
}
