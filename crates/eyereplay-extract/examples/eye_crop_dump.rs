//! Diagnostic: the iris model on fixed eye crops of a video, every output
//! point per frame as CSV on stdout, to compare with a renderer's ground
//! truth.
//!
//!   cargo run --example eye_crop_dump -- VIDEO MODELS_DIR x0 y0 x1 y1 x2 y2 x3 y3 [FRAMES]
//!
//! The eight numbers are the image-left eye's corners then the image-right
//! eye's. Crop knobs (environment, for experiments): SCALE (crop side over
//! the corner extent, default 2.3), DX, DY (crop centre shift, in eye
//! widths along the corner axis and across it), AREA (sub-samples per crop
//! pixel and axis; default automatic, 1 = MediaPipe's single sample).
use eyereplay_extract::*;
use std::path::Path;

fn main() -> Result<()> {
    let a: Vec<String> = std::env::args().skip(1).collect();
    assert!(
        a.len() >= 10,
        "usage: VIDEO MODELS x0 y0 x1 y1 x2 y2 x3 y3 [FRAMES]"
    );
    let f: Vec<f32> = a[2..10]
        .iter()
        .map(|s| s.parse().expect("number"))
        .collect();
    let corners = order_eye_corners([
        (Pt::new(f[0], f[1]), Pt::new(f[2], f[3])),
        (Pt::new(f[4], f[5]), Pt::new(f[6], f[7])),
    ]);
    let frames = a.get(10).map(|s| s.parse::<usize>().expect("frames"));
    let env = |k: &str, d: f32| std::env::var(k).ok().map_or(d, |v| v.parse().expect(k));
    let (scale, dx, dy) = (env("SCALE", EYE_CROP_SCALE), env("DX", 0.0), env("DY", 0.0));
    let rois = corners.map(|(l, r)| {
        let mut roi = Roi::from_two_points(l, r, scale);
        let w = l.dist(r);
        let (s, c) = roi.angle_rad.sin_cos();
        roi.cx += dx * w * c - dy * w * s;
        roi.cy += dx * w * s + dy * w * c;
        roi
    });
    let mut t = EyeCropTracker::new(Models::load(Path::new(&a[1]))?);
    t.area_samples = std::env::var("AREA").ok().map(|v| v.parse().expect("AREA"));
    let mut dec = Decoder::open(Path::new(&a[0]))?;
    let mut head = String::from("frame");
    for e in ["l", "r"] {
        for k in [
            "iris_x", "iris_y", "cl_x", "cl_y", "cr_x", "cr_y", "up_x", "up_y", "lo_x", "lo_y",
            "nx", "ny", "ap",
        ] {
            head += &format!(",{e}_{k}");
        }
        for i in 0..16 {
            head += &format!(",{e}_c{i}_x,{e}_c{i}_y");
        }
        for i in 1..5 {
            head += &format!(",{e}_rim{i}_x,{e}_rim{i}_y");
        }
    }
    println!("{head}");
    let mut n = 0usize;
    dec.frames(|_t, img| {
        let eyes = t.measure_rois(img, &rois)?;
        let mut line = n.to_string();
        for e in &eyes {
            let m = e.measure();
            for p in [
                e.iris,
                e.corner_left,
                e.corner_right,
                e.upper_lid,
                e.lower_lid,
            ] {
                line += &format!(",{:.3},{:.3}", p.x, p.y);
            }
            line += &format!(",{:.5},{:.5},{:.5}", m.nx, m.ny, m.aperture);
            for p in &e.contour[..16] {
                line += &format!(",{:.3},{:.3}", p.x, p.y);
            }
            for p in &e.iris_rim[1..] {
                line += &format!(",{:.3},{:.3}", p.x, p.y);
            }
        }
        println!("{line}");
        n += 1;
        Ok(if frames.is_some_and(|m| n >= m) {
            std::ops::ControlFlow::Break(())
        } else {
            std::ops::ControlFlow::Continue(())
        })
    })?;
    Ok(())
}
