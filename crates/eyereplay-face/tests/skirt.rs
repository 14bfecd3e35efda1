//! The skirt around the face oval meets the backdrop without a seam at the
//! rest pose (needs scripts/setup.sh's models and face assets).

mod common;

use eyereplay_face::*;
use eyereplay_render::Identity;
use nalgebra::Vector3;

/// At the rest pose a frame should be the photo itself, moved into the
/// frame by one similarity (the face filmed by another camera changes it
/// little): compared with the photo mapped by the least-squares similarity
/// from the landmarks' rest projections onto the photo's landmarks (this
/// test's own fit), outside the eye openings and where that map stays
/// inside the photo, the frame's PSNR, in a band of the frame around the
/// face oval (where the skirt is: jaw, ears, hair, neck) and over the
/// whole head box.
fn rest_psnr(scene: &FaceScene, mesh: &CanonicalMesh) -> (f64, f64) {
    let id = &scene.identity;
    let head = scene.rest_pose;
    let state = FaceState {
        head,
        eyes: scene.solve_eyes(&head, (0.5, 0.5), 0.0),
        closure: 0.0,
        pupil_scale: 1.0,
    };
    let (w, h) = (scene.width(), scene.height());
    let mut raster = Rasterizer::new(w, h);
    let mut tm = TexturedMesh::new(vec![], vec![], vec![]);
    let mut frame = RgbImage::filled(w, h, [0, 0, 0]);
    scene.draw(&state, &mut raster, &mut tm, &mut frame);
    let (m, t) = head.to_camera();
    let proj: Vec<[f64; 2]> = id
        .shape_cm
        .iter()
        .map(|p| {
            scene
                .camera
                .project(m * Vector3::from(p.map(f64::from)) + t)
        })
        .collect();
    let a: Vec<Vector3<f64>> = proj.iter().map(|p| Vector3::new(p[0], p[1], 0.0)).collect();
    let b: Vec<Vector3<f64>> = id
        .landmarks_px
        .iter()
        .map(|p| Vector3::new(p[0] as f64, p[1] as f64, 0.0))
        .collect();
    let sim = weighted_procrustes(&a, &b, &vec![1.0; a.len()], true);
    let to_photo = |x: f64, y: f64| {
        let q = sim.rotation * Vector3::new(x, y, 0.0) * sim.scale + sim.translation;
        [q.x, q.y]
    };
    // The face oval (mesh boundary) in the frame: its centre and mean
    // radius; the band reaches from 0.9 to 1.5 of that radius.
    let oval = mesh
        .boundary_loops()
        .into_iter()
        .max_by_key(|l| l.len())
        .expect("an oval");
    let n = oval.len() as f64;
    let c = oval.iter().fold([0.0, 0.0], |s, &i| {
        [
            s[0] + proj[i as usize][0] / n,
            s[1] + proj[i as usize][1] / n,
        ]
    });
    let rad = oval
        .iter()
        .map(|&i| {
            ((proj[i as usize][0] - c[0]).powi(2) + (proj[i as usize][1] - c[1]).powi(2)).sqrt()
        })
        .sum::<f64>()
        / n;
    let eyes: Vec<[f64; 4]> = id
        .eyes
        .iter()
        .map(|e| {
            let pts: Vec<[f64; 2]> = e.contour.iter().map(|&i| proj[i as usize]).collect();
            let lo = |k: usize| pts.iter().map(|p| p[k]).fold(f64::MAX, f64::min) - 3.0;
            let hi = |k: usize| pts.iter().map(|p| p[k]).fold(f64::MIN, f64::max) + 3.0;
            [lo(0), lo(1), hi(0), hi(1)]
        })
        .collect();
    let (mut band, mut head_box) = ((0.0f64, 0usize), (0.0f64, 0usize));
    for y in 0..h {
        for x in 0..w {
            let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
            let r = ((px - c[0]).powi(2) + (py - c[1]).powi(2)).sqrt() / rad;
            if r > 1.5
                || eyes
                    .iter()
                    .any(|e| px > e[0] && px < e[2] && py > e[1] && py < e[3])
            {
                continue;
            }
            let q = to_photo(px, py);
            if q[0] < 0.0
                || q[1] < 0.0
                || q[0] > id.texture.width as f64
                || q[1] > id.texture.height as f64
            {
                continue;
            }
            let want = id.texture.sample(q[0] as f32, q[1] as f32);
            let got = frame.pixel(x, y);
            let se: f64 = (0..3)
                .map(|k| (got[k] as f64 - want[k] as f64).powi(2))
                .sum::<f64>()
                / 3.0;
            head_box.0 += se;
            head_box.1 += 1;
            if r > 0.9 {
                band.0 += se;
                band.1 += 1;
            }
        }
    }
    let psnr = |(se, n): (f64, usize)| {
        10.0 * (255.0f64.powi(2) / (se / n.max(1) as f64).max(1e-9)).log10()
    };
    (psnr(band), psnr(head_box))
}

/// With the skirt's outer ring textured by the photo camera's projection
/// (before), the frame around the oval read 17.0-24.7 dB against the photo
/// (mean 20.0; the photo's chin and neck showed twice, hair and collars
/// were cut along the skirt's edge); with it textured where the backdrop
/// samples the photo, 20.0-30.6 (mean 24.1). Asserted: every photo at
/// least 19.5 dB there (four of six were under it before) and the mean at
/// least 22.5.
#[test]
fn skirt_meets_the_backdrop_at_rest() {
    let (Some(models), Some(mesh)) = (common::models(), common::mesh()) else {
        return;
    };
    let mut fitter = PhotoFitter::new(&models, mesh.clone()).unwrap();
    let mut bands = vec![];
    for name in common::PHOTOS {
        let Some(path) = common::faces_file(name) else {
            return;
        };
        let id = fitter.fit(&path).unwrap();
        let framing = Framing {
            width: 640,
            height: 480,
            vfov_deg: 44.0,
            face_height_frac: 0.5,
            light_dir: [0.0, 0.0, 1.0],
        };
        let scene = FaceScene::new(id, &mesh, Identity::sample(1), &framing);
        let (band, all) = rest_psnr(&scene, &mesh);
        eprintln!(
            "{name}: rest frame against the photo: around the oval {band:.1} dB, head {all:.1} dB"
        );
        assert!(band >= 19.5, "{name}: {band:.1} dB around the oval");
        bands.push(band);
    }
    let mean = bands.iter().sum::<f64>() / bands.len() as f64;
    assert!(mean >= 22.5, "mean {mean:.1} dB around the oval");
}
