//! Renders full-face frames of every bundled identity (or the photos
//! given) at a few gaze targets, head turns and a half blink, saves them
//! as PNG, and reads each back with the extractor's unmodified path
//! (detection, landmarks, iris) to print the target against the measured
//! `(nx, ny)`.
//!
//!   cargo run --release -p eyereplay-face --example face_frames -- OUT_DIR [PHOTO...]

use eyereplay_face::*;
use std::path::PathBuf;

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let out = PathBuf::from(args.first().map(String::as_str).unwrap_or("face_frames"));
    std::fs::create_dir_all(&out).map_err(|source| FaceError::Io {
        path: out.clone(),
        source,
    })?;
    let faces = default_faces_dir();
    let photos: Vec<PathBuf> = if args.len() > 1 {
        args[1..].iter().map(PathBuf::from).collect()
    } else {
        bundled_faces()
    };
    let mesh = CanonicalMesh::load(&faces.join(MESH_FILE))?;
    let mut fitter = PhotoFitter::new(&eyereplay_extract::default_models_dir(), mesh.clone())?;
    for (i, path) in photos.iter().enumerate() {
        let id = fitter.fit(path)?;
        let name = id.name.clone();
        let framing = Framing {
            width: 640,
            height: 480,
            vfov_deg: 43.0,
            face_height_frac: 0.42,
            light_dir: [0.4, 0.5, 1.0],
        };
        let scene = FaceScene::new(
            id,
            &mesh,
            eyereplay_render::Identity::sample(i as u64 + 1),
            &framing,
        );
        let mut raster = Rasterizer::new(640, 480);
        let mut tm = TexturedMesh::new(vec![], vec![], vec![]);
        let mut frame = RgbImage::filled(640, 480, [0, 0, 0]);
        #[allow(clippy::type_complexity)]
        let cases: [(&str, (f64, f64), f64, f64, f64); 8] = [
            ("centre", (0.5, 0.5), 0.0, 0.0, 0.0),
            ("left", (0.2, 0.5), 0.0, 0.0, 0.0),
            ("right", (0.8, 0.5), 0.0, 0.0, 0.0),
            ("up", (0.5, 0.35), 0.0, 0.0, 0.0),
            ("down", (0.5, 0.65), 0.0, 0.0, 0.0),
            ("blink", (0.5, 0.5), 0.0, 0.0, 0.6),
            ("yaw15", (0.5, 0.5), 15.0, 0.0, 0.0),
            ("pitch-10", (0.6, 0.4), -6.0, -10.0, 0.0),
        ];
        for (label, target, yaw, pitch, closure) in cases {
            let mut head = scene.rest_pose;
            head.yaw_deg += yaw;
            head.pitch_deg += pitch;
            let eyes = scene.solve_eyes(&head, target, closure);
            let st = FaceState {
                head,
                eyes,
                closure,
                pupil_scale: 1.0,
            };
            scene.draw(&st, &mut raster, &mut tm, &mut frame);
            let truth = scene.eye_images(&st).map(|e| e.norm());
            frame.save_png(&out.join(format!("{name}_{label}.png")))?;
            let got = fitter.landmarks(&frame)?;
            match got {
                None => println!("{name} {label}: NO FACE"),
                Some(f) => {
                    let basis: Vec<usize> = mesh.procrustes.iter().map(|p| p.0 as usize).collect();
                    let wts: Vec<f64> = mesh.procrustes.iter().map(|p| p.1 as f64).collect();
                    let model: Vec<nalgebra::Vector3<f64>> = basis
                        .iter()
                        .map(|&i| {
                            nalgebra::Vector3::from(scene.identity.shape_cm[i].map(f64::from))
                        })
                        .collect();
                    let obs: Vec<[f64; 2]> = basis
                        .iter()
                        .map(|&i| [f.mesh[i].x as f64, f.mesh[i].y as f64])
                        .collect();
                    let solved = solve_pose(&scene.camera, &model, &obs, &wts, 20);
                    let mut plain = RgbImage::filled(640, 480, [118, 124, 132]);
                    let tmc = scene.identity.textured_mesh(&mesh, false);
                    Rasterizer::new(640, 480).draw(
                        &mut plain,
                        &scene.camera,
                        &head,
                        &tmc,
                        &scene.identity.texture,
                    );
                    if let Some(f2) = fitter.landmarks(&plain)? {
                        let obs2: Vec<[f64; 2]> = basis
                            .iter()
                            .map(|&i| [f2.mesh[i].x as f64, f2.mesh[i].y as f64])
                            .collect();
                        println!(
                            "   plain mesh only: solved yaw {:.1}",
                            solve_pose(&scene.camera, &model, &obs2, &wts, 20).yaw_deg
                        );
                    }
                    println!(
                        "   head yaw drawn {:.1} solved {:.1}; pitch drawn {:.1} solved {:.1}",
                        head.yaw_deg, solved.yaw_deg, head.pitch_deg, solved.pitch_deg
                    );
                    let m: Vec<(f64, f64)> = f
                        .eyes
                        .iter()
                        .map(|e| {
                            let r = e.measure_against(e.corner_left, e.corner_right);
                            (r.nx, r.ny)
                        })
                        .collect();
                    println!(
                        "{name} {label}: target ({:.2},{:.2}) truth L({:.3},{:.3}) R({:.3},{:.3}) measured L({:.3},{:.3}) R({:.3},{:.3}) score {:.2}",
                        target.0, target.1, truth[0].0, truth[0].1, truth[1].0, truth[1].1,
                        m[0].0, m[0].1, m[1].0, m[1].1, f.score
                    );
                }
            }
        }
    }
    Ok(())
}
