//! Rasterizer speed: the canonical face mesh (textured through its own UVs
//! with a 512x512 pattern) drawn in a webcam framing (face 45 % of the
//! frame height) at 640x480 and 1280x720, against the per-frame budget of
//! real time at 25 fps (40 ms for everything: render and encode).
//!
//!   cargo bench -p eyereplay-face --bench raster

use criterion::Criterion;
use eyereplay_face::*;
use std::time::Instant;

const BUDGET_MS: f64 = 40.0;

fn main() {
    let path = default_faces_dir().join(MESH_FILE);
    let mesh = match CanonicalMesh::load(&path) {
        Ok(m) => m,
        Err(e) => {
            eprintln!("SKIPPED: {e}; run scripts/setup.sh");
            return;
        }
    };
    let n = 512usize;
    let mut tex = RgbImage::filled(n, n, [0, 0, 0]);
    for y in 0..n {
        for x in 0..n {
            let i = (y * n + x) * 3;
            tex.data[i] = (x / 2) as u8;
            tex.data[i + 1] = (y / 2) as u8;
            tex.data[i + 2] = if (x / 32 + y / 32) % 2 == 0 { 200 } else { 60 };
        }
    }
    let uv: Vec<[f32; 2]> = mesh
        .uvs
        .iter()
        .map(|t| [t[0] * n as f32, t[1] * n as f32])
        .collect();
    let open: Vec<usize> = mesh.eye_fill_triangles();
    let tris = mesh
        .triangles
        .iter()
        .enumerate()
        .filter(|(i, _)| !open.contains(i))
        .map(|(_, t)| *t)
        .collect();
    let tm = TexturedMesh::new(mesh.positions_cm.clone(), uv, tris);
    let mut c = Criterion::default().configure_from_args();
    let mut lines = vec![];
    for (w, h) in [(640usize, 480usize), (1280, 720)] {
        let cam = Camera::from_vfov(w, h, 45.0);
        // Forehead to chin is 17.66 cm in the canonical mesh.
        let dist = cam.focal_px * 17.66 / (0.45 * h as f64);
        let pose = HeadPose {
            yaw_deg: 15.0,
            pitch_deg: -5.0,
            roll_deg: 3.0,
            translation_cm: [0.0, 0.0, dist],
        };
        let mut frame = RgbImage::filled(w, h, [120, 120, 120]);
        let mut r = Rasterizer::new(w, h);
        c.bench_function(&format!("draw face {w}x{h}"), |b| {
            b.iter(|| r.draw(&mut frame, &cam, &pose, &tm, &tex))
        });
        // The ratio, measured in this run: median of 200 draws.
        let mut ms: Vec<f64> = (0..200)
            .map(|_| {
                let t = Instant::now();
                r.draw(&mut frame, &cam, &pose, &tm, &tex);
                t.elapsed().as_secs_f64() * 1e3
            })
            .collect();
        ms.sort_by(f64::total_cmp);
        let med = ms[ms.len() / 2];
        lines.push(format!(
            "{w}x{h}: {med:.2} ms per frame on {} threads = {:.1} % of the {BUDGET_MS} ms budget of 25 fps real time",
            rayon::current_num_threads(),
            med / BUDGET_MS * 100.0
        ));
    }
    c.final_summary();
    for l in lines {
        println!("{l}");
    }
}
