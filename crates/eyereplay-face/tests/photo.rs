//! Identities from the bundled real photos: fit, reprojection through the
//! rasterizer, iris colour, and the one-line errors.

mod common;

use eyereplay_face::*;
use nalgebra::Vector3;

fn fitter() -> Option<PhotoFitter> {
    let mesh = common::mesh()?;
    let models = common::models()?;
    Some(PhotoFitter::new(&models, mesh).expect("models load"))
}

fn inside(poly: &[[f32; 2]], p: [f32; 2]) -> bool {
    let mut c = false;
    for i in 0..poly.len() {
        let (a, b) = (poly[i], poly[(i + poly.len() - 1) % poly.len()]);
        if (a[1] > p[1]) != (b[1] > p[1])
            && p[0] < (b[0] - a[0]) * (p[1] - a[1]) / (b[1] - a[1]) + a[0]
        {
            c = !c;
        }
    }
    c
}

fn luma(c: [f32; 3]) -> f32 {
    0.299 * c[0] + 0.587 * c[1] + 0.114 * c[2]
}

/// Mean colour of the visible sclera: inside the lid contour, outside 1.2
/// iris radii.
fn sclera_mean(id: &PhotoIdentity) -> [f32; 3] {
    let (mut sum, mut n) = ([0.0f32; 3], 0.0f32);
    for e in &id.eyes {
        let poly = e.contour_px(&id.landmarks_px);
        for y in 0..id.texture.height {
            for x in 0..id.texture.width {
                let p = [x as f32 + 0.5, y as f32 + 0.5];
                let d = ((p[0] - e.iris_center_px[0]).powi(2)
                    + (p[1] - e.iris_center_px[1]).powi(2))
                .sqrt();
                if d > 1.2 * e.iris_radius_px && inside(&poly, p) {
                    let c = id.texture.pixel(x, y);
                    for k in 0..3 {
                        sum[k] += c[k] as f32;
                    }
                    n += 1.0;
                }
            }
        }
    }
    sum.map(|s| s / n.max(1.0))
}

#[test]
fn bundled_photos_fit_and_reproject() {
    let Some(mut fitter) = fitter() else { return };
    let mesh = fitter.mesh().clone();
    let mut cleared_total = 0;
    for name in common::PHOTOS {
        let Some(path) = common::faces_file(name) else {
            return;
        };
        let id = fitter.fit(&path).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(id.landmarks_px.len(), 468);
        assert!(id.face_height_px >= MIN_FACE_HEIGHT_PX);
        // The texture is the photo but where the photo's iris reaches past
        // the lid contour (painted with lid skin).
        let photo = read_image(&path).unwrap();
        let polys: Vec<Vec<[f32; 2]>> = id
            .eyes
            .iter()
            .map(|e| e.contour_px(&id.landmarks_px))
            .collect();
        let mut changed = 0;
        for y in 0..photo.height {
            for x in 0..photo.width {
                if id.texture.pixel(x, y) == photo.pixel(x, y) {
                    continue;
                }
                changed += 1;
                let p = [x as f32 + 0.5, y as f32 + 0.5];
                let on_a_lid = id.eyes.iter().zip(&polys).any(|(e, poly)| {
                    let d = ((p[0] - e.iris_center_px[0]).powi(2)
                        + (p[1] - e.iris_center_px[1]).powi(2))
                    .sqrt();
                    d <= PHOTO_IRIS_REACH_RADII * e.iris_radius_px && !inside(poly, p)
                });
                assert!(on_a_lid, "{name}: texture changed at ({x}, {y})");
            }
        }
        eprintln!("{name}: {changed} lid pixels cleared of the photo's iris");
        cleared_total += changed;
        // Frontal photos: the solved pose stays within a frontal range.
        let p = id.photo_pose;
        assert!(
            p.yaw_deg.abs() < 10.0 && p.roll_deg.abs() < 10.0,
            "{name}: {p:?}"
        );

        // The shape under the photo's camera and pose lands on the landmarks.
        let (m, t) = p.to_camera();
        let worst = id
            .shape_cm
            .iter()
            .zip(&id.landmarks_px)
            .map(|(s, l)| {
                let uv = id
                    .photo_camera
                    .project(m * Vector3::from(s.map(f64::from)) + t);
                ((uv[0] - l[0] as f64).powi(2) + (uv[1] - l[1] as f64).powi(2)).sqrt()
            })
            .fold(0.0, f64::max);
        assert!(worst < 0.01, "{name}: reprojection {worst} px");
        // The shape keeps the canonical face's size: 33-263 within 20 % of 8.89 cm.
        let (a, b) = (id.shape_cm[33], id.shape_cm[263]);
        let eyes_cm =
            ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt();
        assert!(
            (eyes_cm / 8.89 - 1.0).abs() < 0.2,
            "{name}: 33-263 {eyes_cm} cm"
        );

        // Drawn with the photo's camera and pose, the face is the photo.
        let (w, h) = (id.texture.width, id.texture.height);
        let mut frame = RgbImage::filled(w, h, [0, 0, 0]);
        let mut r = Rasterizer::new(w, h);
        let mesh_closed = id.textured_mesh(&mesh, false);
        r.draw(
            &mut frame,
            &id.photo_camera,
            &id.photo_pose,
            &mesh_closed,
            &id.texture,
        );
        let (mut se, mut n) = (0.0f64, 0usize);
        for (k, &d) in r.inv_depth().iter().enumerate() {
            if d > 0.0 {
                for c in 0..3 {
                    let e = frame.data[k * 3 + c] as f64 - id.texture.data[k * 3 + c] as f64;
                    se += e * e;
                }
                n += 1;
            }
        }
        let psnr = 10.0 * (255.0f64.powi(2) / (se / (3 * n) as f64).max(1e-12)).log10();
        // The face oval covers most of the forehead-to-chin square.
        assert!(
            n as f32 > 0.5 * id.face_height_px.powi(2),
            "{name}: {n} face px"
        );
        assert!(psnr > 45.0, "{name}: PSNR {psnr:.1} dB");

        // The extractor finds the same landmarks in the render (face only,
        // black around it): median error under 1 % of the face height
        // (measured 0.37-0.66 %).
        let again = fitter
            .landmarks(&frame)
            .unwrap()
            .expect("face in the render");
        let mut err: Vec<f32> = again
            .mesh
            .iter()
            .zip(&id.landmarks_px)
            .map(|(a, b)| ((a.x - b[0]).powi(2) + (a.y - b[1]).powi(2)).sqrt())
            .collect();
        err.sort_by(f32::total_cmp);
        let median = err[err.len() / 2];
        assert!(
            median < 0.01 * id.face_height_px,
            "{name}: median {median} px"
        );

        // The iris is darker than the visible sclera (which is in shadow in
        // psychopy_face01: luma 30 vs 48), and not black.
        let iris = id.iris_rgb.map(|c| c as f32);
        let sclera = sclera_mean(&id);
        eprintln!("{name}: iris {iris:?} sclera {sclera:?} median landmark error {median} px");
        assert!(
            luma(iris) < 0.8 * luma(sclera),
            "{name}: iris {iris:?} sclera {sclera:?}"
        );
        assert!(luma(iris) > 15.0, "{name}: iris {iris:?}");

        // Open eyes drop exactly the 28 eye-fill triangles.
        assert_eq!(
            id.textured_mesh(&mesh, true).triangles.len(),
            mesh.triangles.len() - 28
        );
    }
    // Some bundled photo's contour cuts its iris (giunchedi's lower lid
    // runs about 2 px above the iris's bottom): the clearing has work.
    assert!(cleared_total > 0);
}

#[test]
fn photo_errors_are_one_line() {
    let Some(mut fitter) = fitter() else { return };
    let dir = tempfile::tempdir().unwrap();

    let junk = dir.path().join("junk.jpg");
    std::fs::write(&junk, b"this is not a picture").unwrap();
    let e = fitter.fit(&junk).unwrap_err().to_string();
    assert!(
        e.starts_with(&junk.display().to_string()) && e.contains("cannot read the image"),
        "{e}"
    );

    let missing = dir.path().join("missing.png");
    let e = fitter.fit(&missing).unwrap_err().to_string();
    assert!(
        e.contains("missing.png") && e.contains("cannot read the image"),
        "{e}"
    );

    let grey = dir.path().join("grey.png");
    RgbImage::filled(256, 256, [128, 128, 128])
        .save_png(&grey)
        .unwrap();
    let e = fitter.fit(&grey).unwrap_err().to_string();
    assert_eq!(e, format!("{}: no face found in the photo", grey.display()));

    // psychopy_face.jpg (face 148 px) halved: found, but too small.
    let Some(path) = common::faces_file("psychopy_face.jpg") else {
        return;
    };
    let full = read_image(&path).unwrap();
    let (w, h) = (full.width / 2, full.height / 2);
    let mut half = RgbImage::filled(w, h, [0, 0, 0]);
    for y in 0..h {
        for x in 0..w {
            for c in 0..3 {
                let s: u32 = [(0, 0), (1, 0), (0, 1), (1, 1)]
                    .iter()
                    .map(|(dx, dy)| full.pixel(2 * x + dx, 2 * y + dy)[c] as u32)
                    .sum();
                half.data[(y * w + x) * 3 + c] = ((s + 2) / 4) as u8;
            }
        }
    }
    let small = dir.path().join("small.png");
    half.save_png(&small).unwrap();
    let e = fitter.fit(&small).unwrap_err().to_string();
    assert!(
        e.starts_with(&small.display().to_string())
            && e.contains("face too small")
            && e.contains(" px"),
        "{e}"
    );
    assert!(!e.contains('\n'));
}

/// A PNG decodes to the bytes FFmpeg gives for it as rgb24 (the peer: the
/// command-line tool's own decoder), in every layout a photo may have:
/// RGB, RGBA (alpha dropped), grey, grey with alpha, a palette and 16 bits
/// a channel. The photos are decoded without FFmpeg, which the Python
/// wheel's build has no PNG decoder in (no zlib).
#[test]
fn a_png_decodes_as_ffmpeg_decodes_it_in_every_layout() {
    let Some(src) = common::faces_file("astronaut.png") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let ffmpeg = |args: &[&str]| {
        let o = std::process::Command::new("ffmpeg")
            .args(["-nostdin", "-v", "error", "-y"])
            .args(args)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    };
    for fmt in [
        "rgb24", "rgba", "gray", "ya8", "pal8", "rgb48be", "rgba64be", "gray16be",
    ] {
        let png = dir.path().join(format!("{fmt}.png"));
        let (s, p) = (src.to_str().unwrap(), png.to_str().unwrap());
        // A corner of the photo keeps the test quick.
        ffmpeg(&["-i", s, "-vf", "crop=96:64:200:180", "-pix_fmt", fmt, p]);
        let raw = dir.path().join(format!("{fmt}.rgb"));
        ffmpeg(&[
            "-i",
            p,
            "-f",
            "rawvideo",
            "-pix_fmt",
            "rgb24",
            raw.to_str().unwrap(),
        ]);
        let want = std::fs::read(&raw).unwrap();
        let got = read_image(&png).unwrap();
        assert_eq!((got.width, got.height), (96, 64), "{fmt}");
        assert!(got.data == want, "{fmt}: differs from FFmpeg's rgb24");
    }
    // Not a PNG past its signature: the file is named in the error.
    let bad = dir.path().join("bad.png");
    std::fs::write(&bad, b"\x89PNG\r\n\x1a\nnot a png at all").unwrap();
    let e = read_image(&bad).unwrap_err().to_string();
    assert!(e.contains("bad.png"), "{e}");
}

/// A phone's portrait photo: the sensor's rows stored on their side, with
/// an EXIF orientation saying how to show them. Grace Hopper's photo
/// turned a quarter anticlockwise (FFmpeg's `transpose=2`) and tagged
/// orientation 6 ("turn a quarter clockwise to show") reads back as the
/// upright photo; the same stored picture without the tag is refused as a
/// face on its side. A JPEG cut off part-way (FFmpeg decodes it without an
/// error, the missing rows green) is named so.
#[test]
fn photos_are_read_upright_and_whole() {
    let Some(mut fitter) = fitter() else { return };
    let Some(src) = common::faces_file("grace_hopper.jpg") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let stored = dir.path().join("stored.jpg");
    let o = std::process::Command::new("ffmpeg")
        .args(["-nostdin", "-v", "error", "-y", "-i"])
        .arg(&src)
        .args(["-vf", "transpose=2", "-q:v", "2"])
        .arg(&stored)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let bytes = std::fs::read(&stored).unwrap();
    // APP1 "Exif": a big-endian TIFF header and one IFD entry,
    // Orientation (0x0112), SHORT, 1 value: 6.
    let mut app1 = vec![0xFF, 0xE1, 0x00, 0x22];
    app1.extend(b"Exif\0\0MM\0\x2A\0\0\0\x08");
    app1.extend([0x00, 0x01, 0x01, 0x12, 0x00, 0x03, 0x00, 0x00, 0x00, 0x01]);
    app1.extend([0x00, 0x06, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00]);
    let tagged = dir.path().join("tagged.jpg");
    std::fs::write(&tagged, [&bytes[..2], &app1, &bytes[2..]].concat()).unwrap();
    assert_eq!(exif_orientation(&tagged), Some(6));
    assert_eq!(exif_orientation(&stored), None);

    let upright = read_image(&src).unwrap();
    let shown = read_image(&tagged).unwrap();
    assert_eq!((shown.width, shown.height), (upright.width, upright.height));
    // Two JPEG generations apart: close, not equal.
    let mean_abs = shown
        .data
        .iter()
        .zip(&upright.data)
        .map(|(a, b)| (*a as f64 - *b as f64).abs())
        .sum::<f64>()
        / shown.data.len() as f64;
    assert!(mean_abs < 4.0, "{mean_abs}");
    let id = fitter.fit(&tagged).unwrap();
    assert!(id.photo_pose.roll_deg.abs() < 10.0, "{:?}", id.photo_pose);

    let e = fitter.fit(&stored).unwrap_err().to_string();
    assert!(
        e.starts_with(&stored.display().to_string()) && e.contains("on its side"),
        "{e}"
    );

    let cut = dir.path().join("cut.jpg");
    let whole = std::fs::read(&src).unwrap();
    assert!(jpeg_is_whole(&whole));
    std::fs::write(&cut, &whole[..whole.len() * 3 / 4]).unwrap();
    let e = fitter.fit(&cut).unwrap_err().to_string();
    assert!(
        e.starts_with(&cut.display().to_string()) && e.contains("cut off"),
        "{e}"
    );
}

/// A file named as a PNG or a JPEG that is not one is named so (FFmpeg's
/// own words for it were "video stream has no picture size").
#[test]
fn a_file_named_as_an_image_that_is_not_one_is_named_so() {
    let dir = tempfile::tempdir().unwrap();
    for (name, kind) in [
        ("text.png", "not a PNG"),
        ("text.jpg", "not a JPEG"),
        ("t.JPEG", "not a JPEG"),
    ] {
        let p = dir.path().join(name);
        std::fs::write(&p, "name,value\na,1\n").unwrap();
        let e = read_image(&p).unwrap_err().to_string();
        assert!(
            e.starts_with(&p.display().to_string()) && e.contains(kind),
            "{e}"
        );
    }
    let empty = dir.path().join("empty.jpg");
    std::fs::write(&empty, b"").unwrap();
    let e = read_image(&empty).unwrap_err().to_string();
    assert!(e.contains("not a JPEG"), "{e}");
}
