//! Writes the example frames shown in the README into docs/img/:
//! `cargo run --release -p eyereplay-render --example readme_frames`.
use eyereplay_render::*;
use std::path::Path;

fn frame(id: &Identity, yaw_deg: f64, pitch_deg: f64, closure: f64) -> (Scene, Vec<u8>) {
    let scene = Scene::new(id, 1280, 720);
    let mut rgb = scene.background_rgb().to_vec();
    let p = EyePose {
        yaw_rad: yaw_deg.to_radians(),
        pitch_rad: pitch_deg.to_radians(),
    };
    // Converge a little, as when reading a screen at 60 cm.
    let v = 3f64.to_radians();
    let poses = [
        EyePose {
            yaw_rad: p.yaw_rad + v,
            ..p
        },
        EyePose {
            yaw_rad: p.yaw_rad - v,
            ..p
        },
    ];
    scene.render_eyes(poses, closure, 1.0, Some(&mut rgb), None, &mut Vec::new());
    (scene, rgb)
}

/// Box-filter downscale by an integer factor.
fn shrink(rgb: &[u8], w: usize, h: usize, f: usize) -> Vec<u8> {
    let (ow, oh) = (w / f, h / f);
    let mut out = vec![0u8; ow * oh * 3];
    for y in 0..oh {
        for x in 0..ow {
            for c in 0..3 {
                let mut s = 0u32;
                for dy in 0..f {
                    for dx in 0..f {
                        s += rgb[((y * f + dy) * w + x * f + dx) * 3 + c] as u32;
                    }
                }
                out[(y * ow + x) * 3 + c] = (s / (f * f) as u32) as u8;
            }
        }
    }
    out
}

fn crop(rgb: &[u8], w: usize, x0: usize, y0: usize, cw: usize, ch: usize) -> Vec<u8> {
    let mut out = Vec::with_capacity(cw * ch * 3);
    for y in y0..y0 + ch {
        out.extend_from_slice(&rgb[(y * w + x0) * 3..(y * w + x0 + cw) * 3]);
    }
    out
}

fn main() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/img");
    std::fs::create_dir_all(&dir).unwrap();
    // The reference face, looking slightly right and up: brows to cheeks
    // (rows 100-500 of the 1280x720 frame) at half size.
    let (scene, rgb) = frame(&Identity::reference(), 8.0, 3.0, 0.0);
    let band = crop(&rgb, 1280, 0, 100, 1280, 400);
    write_png(
        &dir.join("render_reference.png"),
        &shrink(&band, 1280, 400, 2),
        640,
        200,
    )
    .unwrap();
    // One eye at full resolution.
    let g = &scene.geometry()[1];
    let [x0, y0, x1, y1] = g.box_px.map(|v| v as usize);
    write_png(
        &dir.join("render_eye_detail.png"),
        &crop(&rgb, 1280, x0, y0, x1 - x0, y1 - y0),
        x1 - x0,
        y1 - y0,
    )
    .unwrap();
    // Four sampled identities and gazes in a 2x2 grid, eye band at quarter size.
    let mut tiles = Vec::new();
    for (seed, yaw, pitch, cl) in [
        (7u64, -12.0, 0.0, 0.0),
        (28, 0.0, -8.0, 0.0),
        (30, 15.0, 6.0, 0.0),
        (16, -4.0, 0.0, 0.7),
    ] {
        let (_, rgb) = frame(&Identity::sample(seed), yaw, pitch, cl);
        tiles.push(shrink(&crop(&rgb, 1280, 0, 160, 1280, 400), 1280, 400, 4));
    }
    let mut strip = vec![0u8; 640 * 200 * 3];
    for (i, t) in tiles.iter().enumerate() {
        let (ox, oy) = ((i % 2) * 320, (i / 2) * 100);
        for y in 0..100 {
            strip[((oy + y) * 640 + ox) * 3..((oy + y) * 640 + ox + 320) * 3]
                .copy_from_slice(&t[y * 320 * 3..(y + 1) * 320 * 3]);
        }
    }
    write_png(&dir.join("render_identities.png"), &strip, 640, 200).unwrap();
}
