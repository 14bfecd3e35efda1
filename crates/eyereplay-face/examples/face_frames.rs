//! Renders full-face frames of every bundled identity (or the photos
//! given) at a few gaze targets, head turns and a half blink, saves them
//! as PNG, and reads each back with the extractor's unmodified path
//! (detection, landmarks, iris) to print the target against the measured
//! `(nx, ny)`.
//!
//!   cargo run --release -p eyereplay-face --example face_frames -- OUT_DIR [PHOTO...]

mod common;

use eyereplay_face::*;

fn main() -> Result<()> {
    let (out, photos) = common::out_and_photos("face_frames")?;
    let (mesh, mut fitter) = common::mesh_and_fitter()?;
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
                    let px: Vec<[f64; 2]> =
                        f.mesh.iter().map(|p| [p.x as f64, p.y as f64]).collect();
                    let solved = mesh.head_pose(&scene.camera, &scene.identity.shape_cm, &px);
                    println!(
                        "   head yaw drawn {:.1} solved {:.1}; pitch drawn {:.1} solved {:.1}",
                        head.yaw_deg, solved.yaw_deg, head.pitch_deg, solved.pitch_deg
                    );
                    let m: Vec<(f64, f64)> = f
                        .eyes
                        .iter()
                        .map(|e| {
                            let r = e.measure();
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
