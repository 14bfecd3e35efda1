//! Where the iris model finds the lids, corners and iris of rendered eyes,
//! against where the renderer put them: renders a grid of reading-scale
//! gaze targets per identity (no video encoding), runs the iris model on
//! eye crops placed from the render's corners (as `eyereplay evaluate`
//! does), and prints per seed how the model's landmarks follow the truth.
//!
//! `cargo run --release -p eyereplay-cli --example lid_probe -- 0-11 [PNG_DIR]`
//! (needs the models: `EYEREPLAY_MODELS` or .cache/models). With PNG_DIR,
//! annotated close-ups of each eye are written there: the renderer's lid
//! margins blue, the model's eye contour green, its lid points yellow, its
//! corners magenta, its iris red, the true iris cyan.

use eyereplay_core::NormPos;
use eyereplay_extract::{
    order_eye_corners, EyeCropTracker, ImageView, Models, Planes, Pt, Rotation,
};
use eyereplay_render::{write_png, EyePose, Identity, Scene, Side};
use std::path::PathBuf;

const W: usize = 1280;
const H: usize = 720;

/// Least-squares slope of y on x.
fn slope(x: &[f64], y: &[f64]) -> f64 {
    let n = x.len() as f64;
    let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let sxy: f64 = x.iter().zip(y).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = x.iter().map(|a| (a - mx) * (a - mx)).sum();
    sxy / sxx
}

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

/// y of a polyline at x (linear; clamped at the ends).
fn y_at(curve: &[[f64; 2]], x: f64) -> f64 {
    let mut c = curve.to_vec();
    if c[0][0] > c[c.len() - 1][0] {
        c.reverse();
    }
    if x <= c[0][0] {
        return c[0][1];
    }
    for w in c.windows(2) {
        if x <= w[1][0] {
            let t = (x - w[0][0]) / (w[1][0] - w[0][0]);
            return w[0][1] + t * (w[1][1] - w[0][1]);
        }
    }
    c[c.len() - 1][1]
}

fn dot(rgb: &mut [u8], w: usize, h: usize, x: f64, y: f64, r: i32, c: [u8; 3]) {
    let (cx, cy) = (x.floor() as i32, y.floor() as i32);
    for dy in -r..=r {
        for dx in -r..=r {
            let (px, py) = (cx + dx, cy + dy);
            if dx * dx + dy * dy <= r * r
                && px >= 0
                && py >= 0
                && (px as usize) < w
                && (py as usize) < h
            {
                let i = (py as usize * w + px as usize) * 3;
                rgb[i..i + 3].copy_from_slice(&c);
            }
        }
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let seeds: Vec<u64> = args
        .first()
        .map_or("0-11", String::as_str)
        .split(',')
        .flat_map(|p| match p.split_once('-') {
            Some((a, b)) => (a.parse().unwrap()..=b.parse().unwrap()).collect::<Vec<u64>>(),
            None => vec![p.parse().unwrap()],
        })
        .collect();
    let png_dir = args.get(1).map(PathBuf::from);
    if let Some(d) = &png_dir {
        std::fs::create_dir_all(d).unwrap();
    }
    let models_dir = std::env::var_os("EYEREPLAY_MODELS")
        .map(PathBuf::from)
        .unwrap_or_else(eyereplay_extract::default_models_dir);
    eyereplay_extract::init_runtime(&models_dir).unwrap();
    let mut tracker = EyeCropTracker::new(Models::load(&models_dir).unwrap());
    println!(
        "seed  eye  up_slope lo_slope iris_y  ny_slope ny_r   up_off lo_off  inner_dx outer_dx  corner_dy"
    );
    for seed in seeds {
        let id = if seed == 0 {
            Identity::reference()
        } else {
            Identity::sample(seed)
        };
        let scene = Scene::new(&id, W, H);
        if std::env::var_os("PROBE_ID").is_some() {
            let e = &id.eye;
            println!(
                "seed {seed}: {} iris r {:.2} fissure {:.1} up {:.2} lo {:.2} follow {:.2}/{:.2} tilt {:.1} peak {:.2} lash {:.1} px/mm {:.2} skin {:?} hair {:?} cam yaw {:.1} pitch {:.1} roll {:.1} light az {:.0} el {:.0}",
                id.iris.palette, e.iris_radius_mm, e.fissure_width_mm, e.upper_lid_mm, e.lower_lid_mm,
                e.upper_lid_follow, e.lower_lid_follow, e.canthal_tilt_deg, e.upper_peak_frac,
                e.lash_length_mm, scene.px_per_mm(), id.skin_rgb.map(|v| (v * 100.0).round() / 100.0),
                id.hair_rgb.map(|v| (v * 100.0).round() / 100.0),
                id.camera.yaw_deg, id.camera.pitch_deg, id.camera.roll_deg,
                id.lighting.key_azimuth_deg, id.lighting.key_elevation_deg
            );
            continue;
        }
        let geo = scene.geometry();
        let pt = |p: [f64; 2]| Pt::new(p[0] as f32, p[1] as f32);
        let corners = order_eye_corners([
            (pt(geo[0].inner_corner_px), pt(geo[0].outer_corner_px)),
            (pt(geo[1].inner_corner_px), pt(geo[1].outer_corner_px)),
        ]);
        // Per eye: truth and model lid y, iris y, ny; corner offsets.
        #[derive(Default)]
        struct Acc {
            t_up: Vec<f64>,
            m_up: Vec<f64>,
            t_lo: Vec<f64>,
            m_lo: Vec<f64>,
            t_iy: Vec<f64>,
            m_iy: Vec<f64>,
            t_ny: Vec<f64>,
            m_ny: Vec<f64>,
            inner_dx: Vec<f64>,
            outer_dx: Vec<f64>,
            corner_dy: Vec<f64>,
        }
        let mut acc: [Acc; 2] = Default::default();
        let nxs = [0.44, 0.5, 0.56];
        let nys = [0.41, 0.4375, 0.465, 0.4925, 0.52];
        for (ix, &nx) in nxs.iter().enumerate() {
            for (iy, &ny) in nys.iter().enumerate() {
                let target = NormPos { nx, ny };
                let poses: [EyePose; 2] = Side::BOTH.map(|side| scene.solve_pose(side, target));
                let mut rgb = scene.background_rgb().to_vec();
                scene.render_eyes(poses, 0.0, 1.0, Some(&mut rgb), None, &mut Vec::new());
                let img = ImageView {
                    planes: Planes::Rgb24 {
                        data: &rgb,
                        stride: W * 3,
                    },
                    raw_w: W,
                    raw_h: H,
                    rotation: Rotation::None,
                };
                let eyes = tracker.measure(&img, &corners).unwrap();
                let save = png_dir.is_some() && ix == 1 && (iy == 0 || iy == 4);
                for (k, side) in Side::BOTH.into_iter().enumerate() {
                    // Image-left eye first in both.
                    let e = &eyes[k];
                    let t = scene.truth(side, poses[k], 0.0);
                    let [up, lo] = scene.lid_margins_px(side, poses[k], 0.0, 96);
                    let a = &mut acc[k];
                    a.t_up.push(y_at(&up, e.upper_lid.x as f64));
                    a.m_up.push(e.upper_lid.y as f64);
                    a.t_lo.push(y_at(&lo, e.lower_lid.x as f64));
                    a.m_lo.push(e.lower_lid.y as f64);
                    a.t_iy.push(t.iris_px[1]);
                    a.m_iy.push(e.iris.y as f64);
                    a.t_ny.push(t.norm.ny);
                    a.m_ny.push(e.measure().ny);
                    let inner = geo[k].inner_corner_px;
                    let outer = geo[k].outer_corner_px;
                    let (ml, mr) = (e.corner_left, e.corner_right);
                    // Inner corner is the one nearer the image centre.
                    let (mi, mo) = if k == 0 { (mr, ml) } else { (ml, mr) };
                    // Positive: the model's corner lies inside the eye.
                    let inward = |m: Pt, t: [f64; 2], toward: f64| {
                        (m.x as f64 - t[0]) * (toward - t[0]).signum()
                    };
                    a.inner_dx.push(inward(mi, inner, outer[0]));
                    a.outer_dx.push(inward(mo, outer, inner[0]));
                    a.corner_dy.push(mo.y as f64 - outer[1]);
                    if save {
                        // The eye's box, enlarged 2x, annotated.
                        let [bx0, by0, bx1, by1] = geo[k].box_px.map(|v| v as usize);
                        let z = 2;
                        let (cw, ch) = ((bx1 - bx0) * z, (by1 - by0) * z);
                        let mut c = vec![0u8; cw * ch * 3];
                        for y in 0..ch {
                            for x in 0..cw {
                                let i = ((by0 + y / z) * W + bx0 + x / z) * 3;
                                c[(y * cw + x) * 3..(y * cw + x) * 3 + 3]
                                    .copy_from_slice(&rgb[i..i + 3]);
                            }
                        }
                        let mut mark = |x: f64, y: f64, r: i32, col: [u8; 3]| {
                            let (u, v) = ((x - bx0 as f64) * z as f64, (y - by0 as f64) * z as f64);
                            dot(&mut c, cw, ch, u, v, r, col);
                        };
                        for cur in [&up, &lo] {
                            for p in cur {
                                mark(p[0], p[1], 1, [60, 120, 255]);
                            }
                        }
                        for p in e.contour.iter().take(16) {
                            mark(p.x as f64, p.y as f64, 2, [0, 230, 0]);
                        }
                        for p in [e.upper_lid, e.lower_lid] {
                            mark(p.x as f64, p.y as f64, 3, [255, 230, 0]);
                        }
                        for p in [e.corner_left, e.corner_right] {
                            mark(p.x as f64, p.y as f64, 3, [255, 0, 255]);
                        }
                        mark(e.iris.x as f64, e.iris.y as f64, 3, [255, 0, 0]);
                        mark(t.iris_px[0], t.iris_px[1], 2, [0, 255, 255]);
                        let d = png_dir.as_ref().unwrap();
                        write_png(
                            &d.join(format!("seed{seed:02}_{}_ny{iy}.png", ["L", "R"][k])),
                            &c,
                            cw,
                            ch,
                        )
                        .unwrap();
                    }
                }
            }
        }
        for (k, a) in acc.iter().enumerate() {
            let r = {
                let (x, y) = (&a.t_ny, &a.m_ny);
                let (mx, my) = (mean(x), mean(y));
                let sxy: f64 = x.iter().zip(y).map(|(p, q)| (p - mx) * (q - my)).sum();
                let sxx: f64 = x.iter().map(|p| (p - mx).powi(2)).sum();
                let syy: f64 = y.iter().map(|q| (q - my).powi(2)).sum();
                sxy / (sxx * syy).sqrt()
            };
            let up_off: Vec<f64> = a.m_up.iter().zip(&a.t_up).map(|(m, t)| m - t).collect();
            let lo_off: Vec<f64> = a.m_lo.iter().zip(&a.t_lo).map(|(m, t)| m - t).collect();
            println!(
                "{seed:<5} {}    {:6.3}   {:6.3}   {:6.3}  {:6.3}  {:5.3}  {:6.1} {:6.1}  {:7.1}  {:7.1}   {:7.1}",
                if k == 0 { "L" } else { "R" },
                slope(&a.t_up, &a.m_up),
                slope(&a.t_lo, &a.m_lo),
                slope(&a.t_iy, &a.m_iy),
                slope(&a.t_ny, &a.m_ny),
                r,
                mean(&up_off),
                mean(&lo_off),
                mean(&a.inner_dx),
                mean(&a.outer_dx),
                mean(&a.corner_dy),
            );
        }
    }
}
