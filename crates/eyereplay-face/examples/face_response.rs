//! Sweeps the drawn eye-in-head position of each bundled identity (or the
//! photos given) across the aperture, one axis at a time, at the rest pose
//! without webcam effects, and prints what the extractor's unmodified
//! still-image path reads: the response curve that `match_extractor`
//! corrects.
//!
//!   cargo run --release -p eyereplay-face --example face_response -- [PHOTO...]

mod common;

use eyereplay_face::*;

fn main() -> Result<()> {
    let photos = common::photos();
    let (mesh, mut fitter) = common::mesh_and_fitter()?;
    let (w, h) = (640, 480);
    // Extra head yaw (deg) for every probe: how the response changes as
    // the head turns.
    let yaw_off: f64 = std::env::var("EYEREPLAY_PROBE_YAW")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(0.0);
    for (i, path) in photos.iter().enumerate() {
        let id = fitter.fit(path)?;
        let name = id.name.clone();
        let framing = Framing {
            width: w,
            height: h,
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
        let mut raster = Rasterizer::new(w, h);
        let mut tm = TexturedMesh::new(vec![], vec![], vec![]);
        let mut frame = RgbImage::filled(w, h, [0, 0, 0]);
        for axis in 0..2 {
            let mut line = format!("{name} {}:", if axis == 0 { "nx" } else { "ny" });
            for k in 0..9 {
                let v = 0.1 + 0.1 * k as f64;
                let target = if axis == 0 { (v, 0.5) } else { (0.5, v) };
                let mut head = scene.rest_pose;
                head.yaw_deg += yaw_off;
                let eyes = scene.solve_eyes(&head, target, 0.0);
                let st = FaceState {
                    head,
                    eyes,
                    closure: 0.0,
                    pupil_scale: 1.0,
                };
                let truth = scene.eye_images(&st);
                let t = 0.5 * (truth[0].norm().0 + truth[1].norm().0);
                let tv = 0.5 * (truth[0].norm().1 + truth[1].norm().1);
                scene.draw(&st, &mut raster, &mut tm, &mut frame);
                let m = read_frame(&mut fitter, &frame)?.map(|n| (n.nx, n.ny));
                let drawn = if axis == 0 { t } else { tv };
                let got = m.map_or(f64::NAN, |m| if axis == 0 { m.0 } else { m.1 });
                line += &format!(" {v:.1}->{drawn:.2}->{got:.3}");
            }
            println!("{line}");
        }
    }
    Ok(())
}
