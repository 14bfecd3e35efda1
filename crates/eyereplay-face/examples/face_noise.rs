//! The read-back's noise floor: a still eye (fixed target, head still)
//! rendered to H.264 and read back by the extractor's video path; prints
//! the frame-to-frame sd of the extracted nx, ny per identity, size and
//! look (dev tool: what limits r at conversation scale).
//!
//!   cargo run --release -p eyereplay-face --example face_noise
use eyereplay_core::{Canvas, CanvasPos};
use eyereplay_extract::{extract_video_to_csv, ExtractOptions};
use eyereplay_face::coordination::{CoordinationParams, HeadDynamics, Task};
use eyereplay_face::webcam::{WebcamLook, WebcamRanges};
mod common;

use eyereplay_face::*;
use eyereplay_render::{EncoderSettings, GazeMapping, Identity};

fn sd(v: &[f64]) -> f64 {
    let m = v.iter().sum::<f64>() / v.len() as f64;
    (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / v.len() as f64).sqrt()
}

fn main() -> Result<()> {
    let faces = default_faces_dir();
    let (mesh, mut fitter) = common::mesh_and_fitter()?;
    let dir = std::env::temp_dir().join("eyereplay_face_noise");
    std::fs::create_dir_all(&dir).unwrap();
    for photo in ["astronaut.png", "grace_hopper.jpg"] {
        let id = fitter.fit(&faces.join(photo))?;
        for (w, h) in [(640, 480), (1280, 720)] {
            for clean in [false, true] {
                let mut look = WebcamRanges::default().sample(5);
                if clean {
                    let v = look.vfov_deg;
                    look = WebcamLook::identity();
                    look.vfov_deg = v;
                    look.bitrate_kbps = 8000.0;
                }
                let framing = Framing {
                    width: w,
                    height: h,
                    vfov_deg: look.vfov_deg,
                    face_height_frac: 0.42,
                    light_dir: look.light_dir_head(),
                };
                let scene = FaceScene::new(id.clone(), &mesh, Identity::sample(2), &framing);
                let canvas = Canvas::default();
                let traj = vec![
                    CanvasPos {
                        x_px: 640.0,
                        y_px: 360.0
                    };
                    100
                ];
                let params = FaceSessionParams {
                    fps: 25.0,
                    mapping: GazeMapping::new(canvas),
                    natural_blinks: false,
                    blink_rate_per_min: 0.0,
                    task: Task::Saccades,
                    reading_frames: None,
                    coordination: CoordinationParams::default(),
                    dynamics: HeadDynamics::default(),
                    sway_rms: [0.0; 6],
                    look,
                    encoder: EncoderSettings::default(),
                    seed: 1,
                    pose_slopes: None,
                    source_head: None,
                    head_path: None,
                };
                let mp4 = dir.join("n.mp4");
                render_face_session(
                    &scene,
                    &traj,
                    None,
                    &params,
                    &mp4,
                    &dir.join("t.csv"),
                    &dir.join("h.csv"),
                )?;
                let ex =
                    extract_video_to_csv(&mp4, &dir.join("x.csv"), &ExtractOptions::default())?;
                let (xs, ys): (Vec<f64>, Vec<f64>) = ex
                    .rows
                    .iter()
                    .filter_map(|r| {
                        r.eyes
                            .map(|e| (0.5 * (e[0].nx + e[1].nx), 0.5 * (e[0].ny + e[1].ny)))
                    })
                    .unzip();
                println!(
                    "{photo} {w}x{h} {}: nx sd {:.4}, ny sd {:.4} over {} frames",
                    if clean { "clean" } else { "webcam" },
                    sd(&xs),
                    sd(&ys),
                    xs.len()
                );
            }
        }
    }
    Ok(())
}
