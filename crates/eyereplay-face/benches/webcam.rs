//! Webcam-look speed: the default look (`WebcamRanges::default().sample(1)`)
//! applied to a textured frame at 640x480 and 1280x720, still and with a
//! head moving 4 px per frame, against the per-frame budget of real time
//! at 25 fps (40 ms for everything: render, webcam look and encode).
//! Where the CPU has AVX-512, the AVX2 build is timed too, in the same run
//! (the same bytes; `Webcam::limit_simd`).
//!
//!   cargo bench -p eyereplay-face --bench webcam

use criterion::Criterion;
use eyereplay_face::webcam::{Simd, Webcam, WebcamRanges};
use eyereplay_face::RgbImage;
use std::time::Instant;

const BUDGET_MS: f64 = 40.0;

fn main() {
    let look = WebcamRanges::default().sample(1);
    println!("look: {look:?}");
    let mut c = Criterion::default().configure_from_args();
    let mut lines = vec![];
    for (w, h) in [(640usize, 480usize), (1280, 720)] {
        // A smooth pattern with some edges, like a face on a background.
        let mut input = RgbImage::filled(w, h, [0, 0, 0]);
        for y in 0..h {
            for x in 0..w {
                let i = (y * w + x) * 3;
                input.data[i] = (x * 255 / w) as u8;
                input.data[i + 1] = (y * 255 / h) as u8;
                input.data[i + 2] = if (x / 32 + y / 32) % 2 == 0 { 200 } else { 60 };
            }
        }
        let mut cam = Webcam::new(&look, w, h);
        for (label, motion) in [("still", [0.0f32, 0.0]), ("moving 4 px", [3.0, -2.6])] {
            // The cost does not depend on the pixel values, so criterion
            // applies the look to the same frame over and over.
            let mut frame = input.clone();
            let mut k = 0u64;
            c.bench_function(&format!("webcam {w}x{h} {label}"), |b| {
                b.iter(|| {
                    k += 1;
                    cam.apply(&mut frame, k, motion)
                })
            });
            // The ratio, measured in this run: median of 200 fresh frames.
            let (med, best) = median_ms(&mut cam, &input, &mut frame, motion);
            // The fastest frame too: on a busy machine the median carries
            // other processes' time.
            lines.push(format!(
                "{w}x{h} {label}: {med:.2} ms per frame (fastest {best:.2}) on {} threads = {:.1} % of the {BUDGET_MS} ms budget of 25 fps real time ({:?} build)",
                rayon::current_num_threads(),
                med / BUDGET_MS * 100.0,
                cam.simd()
            ));
            if cam.simd() > Simd::Avx2 {
                let mut avx2 = Webcam::new(&look, w, h);
                avx2.limit_simd(Simd::Avx2);
                let (m2, b2) = median_ms(&mut avx2, &input, &mut frame, motion);
                lines.push(format!(
                    "    the AVX2 build: {m2:.2} ms (fastest {b2:.2}); {:?} takes {:.2}x its time",
                    cam.simd(),
                    med / m2
                ));
            }
        }
    }
    c.final_summary();
    for l in lines {
        println!("{l}");
    }
}

/// Median and fastest of 200 applications of `cam` to fresh copies of
/// `input`, ms.
fn median_ms(
    cam: &mut Webcam,
    input: &RgbImage,
    frame: &mut RgbImage,
    motion: [f32; 2],
) -> (f64, f64) {
    let mut ms: Vec<f64> = (0..200u64)
        .map(|k| {
            frame.data.copy_from_slice(&input.data);
            let t = Instant::now();
            cam.apply(frame, k, motion);
            t.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    ms.sort_by(f64::total_cmp);
    (ms[ms.len() / 2], ms[0])
}
