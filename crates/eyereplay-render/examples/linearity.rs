//! Prints the Pearson r between input and ground-truth iris centre per axis
//! and the amplitude ratio, for reading- and conversation-scale input.
use eyereplay_render::*;

fn pearson(a: &[f64], b: &[f64]) -> f64 {
    eyereplay_signal::pearson(a, b).unwrap_or(f64::NAN)
}

fn main() {
    let seeds: Vec<u64> = match std::env::args().nth(1) {
        Some(n) => (1..=n.parse::<u64>().unwrap()).collect(),
        None => vec![0, 7, 28],
    };
    for seed in seeds {
        let id = if seed == 0 {
            Identity::reference()
        } else {
            Identity::sample(seed)
        };
        let p = RenderParams::new(id);
        let scene = Scene::new(&p.identity, p.width, p.height);
        for (label, traj) in [
            ("reading", reading_trajectory(1500, 1280.0, 720.0)),
            (
                "conversation",
                conversation_trajectory(1500, 1280.0, 720.0, seed + 1),
            ),
        ] {
            let truth = solve_truth(&scene, &traj, None, &p);
            let ix: Vec<f64> = traj.iter().map(|c| c.x_px).collect();
            let iy: Vec<f64> = traj.iter().map(|c| c.y_px).collect();
            let mut out = format!("seed {seed:2} {label:12}");
            for k in 0..2 {
                let tx: Vec<f64> = truth.iter().map(|t| t.eyes[k].iris_px[0]).collect();
                let ty: Vec<f64> = truth.iter().map(|t| t.eyes[k].iris_px[1]).collect();
                out += &format!(
                    " eye{k} r_x {:.5} r_y {:.5}",
                    pearson(&ix, &tx),
                    pearson(&iy, &ty)
                );
            }
            let cal = p.mapping.calibration;
            let sd = |v: &[f64]| {
                let m = v.iter().sum::<f64>() / v.len() as f64;
                (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / v.len() as f64).sqrt()
            };
            let src: Vec<f64> = traj.iter().map(|c| cal.canvas_to_norm(*c).nx).collect();
            let got: Vec<f64> = truth
                .iter()
                .map(|t| (t.eyes[0].norm.nx + t.eyes[1].norm.nx) / 2.0)
                .collect();
            let srcy: Vec<f64> = traj.iter().map(|c| cal.canvas_to_norm(*c).ny).collect();
            let goty: Vec<f64> = truth
                .iter()
                .map(|t| (t.eyes[0].norm.ny + t.eyes[1].norm.ny) / 2.0)
                .collect();
            out += &format!(
                " amplitude x {:.3} y {:.3}",
                sd(&got) / sd(&src),
                sd(&goty) / sd(&srcy)
            );
            println!("{out}");
        }
    }
}
