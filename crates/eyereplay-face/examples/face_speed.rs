//! Time per frame of each stage of the full-face mode at 640x480 and
//! 1280x720 (dev tool; the user-facing bench is `eyereplay render --bench`).
use eyereplay_face::webcam::{Webcam, WebcamRanges};
use eyereplay_face::*;
use std::time::Instant;

fn main() -> Result<()> {
    let faces = default_faces_dir();
    let mesh = CanonicalMesh::load(&faces.join(MESH_FILE))?;
    let mut fitter = PhotoFitter::new(&eyereplay_extract::default_models_dir(), mesh.clone())?;
    let id = fitter.fit(&faces.join("astronaut.png"))?;
    for (w, h) in [(640, 480), (1280, 720)] {
        let look = WebcamRanges::default().sample(1);
        let framing = Framing {
            width: w,
            height: h,
            vfov_deg: look.vfov_deg,
            face_height_frac: 0.45,
            light_dir: look.light_dir_head(),
        };
        let scene = FaceScene::new(
            id.clone(),
            &mesh,
            eyereplay_render::Identity::sample(1),
            &framing,
        );
        let mut raster = Rasterizer::new(w, h);
        let mut tm = TexturedMesh::new(vec![], vec![], vec![]);
        let mut frame = RgbImage::filled(w, h, [0, 0, 0]);
        let mut cam = Webcam::new(&look, w, h);
        let mut yuv = vec![0u8; w * h * 3 / 2];
        let n = 100;
        let (mut t_solve, mut t_draw, mut t_cam, mut t_yuv) = (0.0, 0.0, 0.0, 0.0);
        for i in 0..n {
            let mut head = scene.rest_pose;
            head.yaw_deg += 3.0 * (i as f64 * 0.1).sin();
            let t0 = Instant::now();
            let eyes = scene.solve_eyes(&head, (0.5 + 0.1 * (i as f64 * 0.3).sin(), 0.5), 0.0);
            let t1 = Instant::now();
            let st = FaceState {
                head,
                eyes,
                closure: 0.0,
                pupil_scale: 1.0,
            };
            scene.draw(&st, &mut raster, &mut tm, &mut frame);
            let t2 = Instant::now();
            cam.apply(&mut frame, i, [1.0, 0.0]);
            let t3 = Instant::now();
            eyereplay_render::rgb_to_yuv420(&frame.data, w, [0, 0, w, h], &mut yuv, w, h);
            let t4 = Instant::now();
            t_solve += (t1 - t0).as_secs_f64();
            t_draw += (t2 - t1).as_secs_f64();
            t_cam += (t3 - t2).as_secs_f64();
            t_yuv += (t4 - t3).as_secs_f64();
        }
        let ms = |t: f64| 1e3 * t / n as f64;
        println!(
            "{w}x{h}: solve {:.2} ms, draw {:.2} ms, webcam {:.2} ms, yuv {:.2} ms per frame",
            ms(t_solve),
            ms(t_draw),
            ms(t_cam),
            ms(t_yuv)
        );
    }
    Ok(())
}
