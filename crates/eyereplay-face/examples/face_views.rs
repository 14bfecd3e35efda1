//! Fits every bundled face photo (or the photos given) and renders each
//! identity at its photo pose and in a 640x480 webcam framing at yaw -20,
//! 0 and +20 deg; saves the PNGs and prints fit facts and the
//! rasterizer's time per frame against the 40 ms frame budget of 25 fps.
//!
//!   cargo run --release -p eyereplay-face --example face_views -- OUT_DIR [PHOTO...]

mod common;

use eyereplay_face::*;
use std::time::Instant;

/// A webcam-like framing: 45 deg vertical field of view, the face
/// (forehead to chin) at `share` of the frame height.
fn webcam(width: usize, height: usize, id: &PhotoIdentity, share: f64) -> (Camera, f64) {
    let cam = Camera::from_vfov(width, height, 45.0);
    let s = &id.shape_cm;
    let (a, b) = (s[lm::FOREHEAD], s[lm::CHIN]);
    let face_cm = ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)) as f64;
    let dist = cam.focal_px * face_cm.sqrt() / (share * height as f64);
    (cam, dist)
}

fn psnr_masked(a: &RgbImage, b: &RgbImage, mask: &[f32]) -> (f64, usize) {
    let (mut se, mut n) = (0.0f64, 0usize);
    for (k, &m) in mask.iter().enumerate() {
        if m > 0.0 {
            for c in 0..3 {
                let d = a.data[k * 3 + c] as f64 - b.data[k * 3 + c] as f64;
                se += d * d;
            }
            n += 1;
        }
    }
    let mse = se / (3 * n.max(1)) as f64;
    (10.0 * (255.0f64 * 255.0 / mse.max(1e-12)).log10(), n)
}

fn main() -> Result<()> {
    let (out, photos) = common::out_and_photos("face_views")?;
    let (mesh, mut fitter) = common::mesh_and_fitter()?;
    let mut raster_ms = vec![];
    for path in &photos {
        let t0 = Instant::now();
        let id = fitter.fit(path)?;
        let fit_ms = t0.elapsed().as_secs_f64() * 1e3;
        let p = id.photo_pose;
        println!(
            "{}: {}x{}, face {:.0} px, photo pose yaw {:.1} pitch {:.1} roll {:.1} deg at {:.0} cm, iris rgb {:?} (r {:.1}/{:.1} px), fit {:.0} ms",
            id.name,
            id.texture.width,
            id.texture.height,
            id.face_height_px,
            p.yaw_deg,
            p.pitch_deg,
            p.roll_deg,
            p.translation_cm[2],
            id.iris_rgb,
            id.eyes[0].iris_radius_px,
            id.eyes[1].iris_radius_px,
            fit_ms
        );
        // 1. The photo's own camera and pose: the render must give the photo back.
        let (w, h) = (id.texture.width, id.texture.height);
        let closed = id.textured_mesh(&mesh, false);
        let mut frame = RgbImage::filled(w, h, [0, 0, 0]);
        let mut r = Rasterizer::new(w, h);
        r.draw(
            &mut frame,
            &id.photo_camera,
            &id.photo_pose,
            &closed,
            &id.texture,
        );
        let (psnr, n) = psnr_masked(&frame, &id.texture, r.inv_depth());
        frame.save_png(&out.join(format!("{}_photo_pose.png", id.name)))?;
        // Re-extract from the render (face only, black around it).
        let again = fitter.landmarks(&frame)?;
        let lm_err = again.map(|f| {
            let mut e: Vec<f32> = f
                .mesh
                .iter()
                .zip(&id.landmarks_px)
                .map(|(a, b)| ((a.x - b[0]).powi(2) + (a.y - b[1]).powi(2)).sqrt())
                .collect();
            e.sort_by(f32::total_cmp);
            (e[e.len() / 2], e[e.len() * 95 / 100])
        });
        println!(
            "  photo pose: PSNR {psnr:.1} dB over {n} face px; landmarks re-extracted from the render: median/p95 error {lm_err:?} px"
        );
        // 2. Webcam framing, yaw -20 / 0 / +20; eyes open over magenta at 0.
        let open = id.textured_mesh(&mesh, true);
        let (cam, dist) = webcam(640, 480, &id, 0.45);
        let mut r = Rasterizer::new(640, 480);
        for (yaw, eyes_open) in [(-20.0, false), (0.0, false), (20.0, false), (0.0, true)] {
            let pose = HeadPose {
                yaw_deg: yaw,
                pitch_deg: 0.0,
                roll_deg: 0.0,
                translation_cm: [0.0, 0.0, dist],
            };
            let bg = if eyes_open {
                [255, 0, 255]
            } else {
                [118, 124, 132]
            };
            let mut frame = RgbImage::filled(640, 480, bg);
            let m = if eyes_open { &open } else { &closed };
            let st = r.draw(&mut frame, &cam, &pose, m, &id.texture);
            let tag = if eyes_open { "_open" } else { "" };
            frame.save_png(&out.join(format!("{}_yaw{:+.0}{tag}.png", id.name, yaw)))?;
            if yaw == 0.0 && !eyes_open {
                // Time the draw alone (background fill excluded), best of 50.
                let mut best = f64::MAX;
                for _ in 0..50 {
                    let t = Instant::now();
                    r.draw(&mut frame, &cam, &pose, m, &id.texture);
                    best = best.min(t.elapsed().as_secs_f64() * 1e3);
                }
                raster_ms.push(best);
                println!(
                    "  640x480 yaw 0: {} triangles, {} px, draw {best:.2} ms ({:.0}x inside the 40 ms budget of 25 fps)",
                    st.triangles_drawn,
                    st.pixels_written,
                    40.0 / best
                );
            }
        }
    }
    let mean = raster_ms.iter().sum::<f64>() / raster_ms.len().max(1) as f64;
    println!(
        "rasterizer, 640x480, {} threads: {mean:.2} ms per frame (budget 40 ms at 25 fps: {:.1} %)",
        rayon::current_num_threads(),
        mean / 40.0 * 100.0
    );
    Ok(())
}
