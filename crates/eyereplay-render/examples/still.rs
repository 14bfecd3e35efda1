//! Renders one still for looking at the model: `still SEED YAW_DEG PITCH_DEG
//! CLOSURE OUT.png [X,Y,W,H crop]` (seed 0 is the reference face).
use eyereplay_render::*;
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let seed: u64 = args.get(1).map(|s| s.parse().unwrap()).unwrap_or(0);
    let yaw: f64 = args.get(2).map(|s| s.parse().unwrap()).unwrap_or(0.0);
    let pitch: f64 = args.get(3).map(|s| s.parse().unwrap()).unwrap_or(0.0);
    let closure: f64 = args.get(4).map(|s| s.parse().unwrap()).unwrap_or(0.0);
    let out = args.get(5).cloned().unwrap_or("/tmp/still.png".into());
    let id = if seed == 0 {
        Identity::reference()
    } else {
        Identity::sample(seed)
    };
    let t = std::time::Instant::now();
    let scene = Scene::new(&id, 1280, 720);
    eprintln!("scene {:?}", t.elapsed());
    let mut rgb = scene.background_rgb().to_vec();
    let mut scratch = Vec::new();
    let p = EyePose {
        yaw_rad: yaw.to_radians(),
        pitch_rad: pitch.to_radians(),
    };
    let t = std::time::Instant::now();
    scene.render_eyes([p, p], closure, 1.0, Some(&mut rgb), None, &mut scratch);
    eprintln!("frame {:?}", t.elapsed());
    if let Some(c) = args.get(6) {
        let v: Vec<usize> = c.split(',').map(|x| x.parse().unwrap()).collect();
        let (x0, y0, w, h) = (v[0], v[1], v[2], v[3]);
        let mut crop = Vec::new();
        for y in y0..y0 + h {
            crop.extend_from_slice(&rgb[(y * 1280 + x0) * 3..(y * 1280 + x0 + w) * 3]);
        }
        write_png(std::path::Path::new(&out), &crop, w, h).unwrap();
    } else {
        write_png(std::path::Path::new(&out), &rgb, 1280, 720).unwrap();
    }
    for side in Side::BOTH {
        eprintln!("{:?}", scene.truth(side, p, closure));
    }
    eprintln!("{:?}", scene.geometry());
}
