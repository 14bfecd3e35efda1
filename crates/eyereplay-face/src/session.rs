//! A whole full-face session: trajectory in, webcam-like MP4 and ground
//! truth out ([`render_face_session`]).
//!
//! Per frame, in order:
//! 1. the gaze target `(nx, ny)` from the canvas position (the same
//!    [`GazeMapping`] as the close-up mode);
//! 2. the eye-in-head rotation that puts the iris there at the rest pose;
//!    from it the gaze in the world by the eye-head coordination model
//!    ([`crate::coordination`]: the gaze whose eye share is that rotation),
//!    the head's part of it with its delayed, damped dynamics, plus drift
//!    and sway ([`Sway`]);
//! 3. the eye-in-head rotation solved again under the frame's head pose,
//!    so the iris lands at `(nx, ny)` in the aperture as the extractor
//!    measures it in the image: the source trajectory stays the eye-in-head
//!    position, whatever the head does;
//! 4. the frame drawn ([`FaceScene::draw`]), given the webcam look
//!    ([`Webcam`]), converted to yuv420p and piped to x264 at the look's
//!    video-call bitrate.
//!
//! Frames are solved in parallel and drawn one after another (each frame's
//! drawing is parallel inside); the output does not depend on the number
//! of threads.

use crate::coordination::{head_track, CoordinationParams, HeadDynamics, Sway, Task};
use crate::error::Result;
use crate::pose::HeadPose;
use crate::raster::{Rasterizer, RgbImage, TexturedMesh};
use crate::scene::{FaceScene, FaceState};
use crate::webcam::{Webcam, WebcamLook};
use eyereplay_core::CanvasPos;
use eyereplay_dataset::{EyeTruthRow, TruthRow};
use eyereplay_render::{
    check_trajectory, closure_track, cpu_times, rgb_to_yuv420, BenchReport, Encoder,
    EncoderSettings, FrameSink, GazeMapping,
};
use rayon::prelude::*;
use serde::Serialize;
use std::path::Path;
use std::time::Instant;

/// Columns of the head ground truth written beside each session's truth
/// CSV: the head pose relative to the rest pose (degrees; translation in
/// cm, camera frame x right, y down, z away), the eye-in-head rotation
/// (mean of both eyes) and the gaze in the world (head + eye).
pub const HEAD_TRUTH_HEADER: &str = "frame,head_yaw_deg,head_pitch_deg,head_roll_deg,\
head_x_cm,head_y_cm,head_z_cm,eye_yaw_deg,eye_pitch_deg,gaze_yaw_deg,gaze_pitch_deg";

/// The head turns the mode draws, at most (deg), coordination and sway
/// together: a frontal photo's texture and the backdrop's 2D warp stay
/// plausible within about this range (beyond it the far cheek stretches
/// and the photo's own head shows beside the turned one).
pub const HEAD_YAW_LIMIT_DEG: f64 = 12.0;
pub const HEAD_PITCH_LIMIT_DEG: f64 = 8.0;

/// What a session varies besides the identity.
#[derive(Clone, Debug)]
pub struct FaceSessionParams {
    pub fps: f64,
    pub mapping: GazeMapping,
    pub natural_blinks: bool,
    pub blink_rate_per_min: f64,
    pub task: Task,
    pub coordination: CoordinationParams,
    pub dynamics: HeadDynamics,
    /// RMS of the drift and sway: yaw, pitch, roll (deg), x, y, z (cm).
    pub sway_rms: [f64; 6],
    pub look: WebcamLook,
    pub encoder: EncoderSettings,
    pub seed: u64,
    /// How the extractor's reading moves as the head turns (see
    /// [`crate::measure_pose_slopes`]); subtracted per frame. `None`: no
    /// correction.
    pub pose_slopes: Option<[[f64; 2]; 2]>,
}

/// What a session render did.
#[derive(Clone, Debug, Default, Serialize)]
pub struct FaceSessionStats {
    pub frames: usize,
    pub clamped_points: usize,
    pub blink_frames: usize,
    /// Largest head turn from the rest pose in the session (deg).
    pub max_head_yaw_deg: f64,
    pub max_head_pitch_deg: f64,
    pub render_s: f64,
    pub total_s: f64,
}

/// One frame's state and truth.
struct Solved {
    state: FaceState,
    row: TruthRow,
    /// The head relative to the rest pose, and the mean eye-in-head angles.
    head: HeadPose,
    eye_deg: (f64, f64),
}

/// The gaze angle (deg) whose eye-in-head share is `eye_deg` on one axis:
/// the inverse of `gaze - head(gaze)` (monotone in the gaze), by bisection.
fn gaze_for_eye(eye_deg: f64, eye_of_gaze: impl Fn(f64) -> f64) -> f64 {
    let (mut lo, mut hi) = (-120.0f64, 120.0f64);
    for _ in 0..50 {
        let mid = 0.5 * (lo + hi);
        if eye_of_gaze(mid) < eye_deg {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

fn solve_frames(
    scene: &FaceScene,
    traj: &[CanvasPos],
    blinks: Option<&[bool]>,
    p: &FaceSessionParams,
) -> Vec<Solved> {
    let n = traj.len();
    let closure = closure_track(
        n,
        p.fps,
        blinks,
        p.natural_blinks.then_some(p.blink_rate_per_min),
        p.seed,
    );
    let targets: Vec<(f64, f64)> = traj
        .iter()
        .map(|&c| {
            let t = p.mapping.target_norm(c);
            (t.nx, t.ny)
        })
        .collect();
    let rest = scene.rest_pose;
    // Eye-in-head at the rest pose, then the gaze whose eye share it is.
    let eye_rest: Vec<(f64, f64)> = targets
        .par_iter()
        .map(|&t| {
            let e = scene.solve_eyes(&rest, t, 0.0);
            (
                0.5 * (e[0].yaw_rad + e[1].yaw_rad).to_degrees(),
                0.5 * (e[0].pitch_rad + e[1].pitch_rad).to_degrees(),
            )
        })
        .collect();
    let c = p.coordination;
    let gaze: Vec<(f64, f64)> = eye_rest
        .iter()
        .map(|&(eh, ev)| {
            let h = gaze_for_eye(eh, |g| g - c.head_target(p.task, g, 0.0).0);
            let v = gaze_for_eye(ev, |g| g - c.head_target(p.task, 0.0, g).1);
            (h, v)
        })
        .collect();
    let track = head_track(&c, &p.dynamics, p.task, &gaze, 1.0 / p.fps);
    let sway = Sway::new(p.seed ^ 0x5ea7, p.sway_rms);
    (0..n)
        .into_par_iter()
        .map(|i| {
            let s = sway.at(i as f64 / p.fps);
            let (hh, hv) = track.head_deg[i];
            let rel = HeadPose {
                yaw_deg: (hh + s[0]).clamp(-HEAD_YAW_LIMIT_DEG, HEAD_YAW_LIMIT_DEG),
                pitch_deg: (hv + s[1]).clamp(-HEAD_PITCH_LIMIT_DEG, HEAD_PITCH_LIMIT_DEG),
                roll_deg: s[2],
                translation_cm: [s[3], s[4], s[5]],
            };
            let head = HeadPose {
                yaw_deg: rest.yaw_deg + rel.yaw_deg,
                pitch_deg: rest.pitch_deg + rel.pitch_deg,
                roll_deg: rest.roll_deg + rel.roll_deg,
                translation_cm: [
                    rest.translation_cm[0] + s[3],
                    rest.translation_cm[1] + s[4],
                    rest.translation_cm[2] + s[5],
                ],
            };
            // The extractor reads a turned head's eye a little off: draw
            // against that, in drawn units (through the response's gains).
            let mut target = targets[i];
            if let Some(sl) = p.pose_slopes {
                let gain = p
                    .mapping
                    .extractor_response
                    .map_or([1.0, 1.0], |m| [m.a[0][0], m.a[1][1]]);
                for (k, t) in [&mut target.0, &mut target.1].into_iter().enumerate() {
                    *t -= (sl[k][0] * rel.yaw_deg + sl[k][1] * rel.pitch_deg) / gain[k];
                }
            }
            let eyes = scene.solve_eyes(&head, target, closure[i]);
            let pupil_scale = 1.0 + 0.08 * (std::f64::consts::TAU * 0.07 * i as f64 / p.fps).sin();
            let state = FaceState {
                head,
                eyes,
                closure: closure[i],
                pupil_scale,
            };
            let img = scene.eye_images(&state);
            let eye_row = |k: usize| {
                let (nx, ny, aperture) = img[k].norm();
                EyeTruthRow {
                    yaw_deg: eyes[k].yaw_rad.to_degrees(),
                    pitch_deg: eyes[k].pitch_rad.to_degrees(),
                    iris_px: img[k].iris_px,
                    nx,
                    ny,
                    aperture,
                }
            };
            let row = TruthRow {
                frame: i as u64,
                x_px: traj[i].x_px,
                y_px: traj[i].y_px,
                eyes: [eye_row(0), eye_row(1)],
                lid_closure: closure[i],
                blink: closure[i] >= 0.5,
            };
            let eye_deg = (
                0.5 * (eyes[0].yaw_rad + eyes[1].yaw_rad).to_degrees(),
                0.5 * (eyes[0].pitch_rad + eyes[1].pitch_rad).to_degrees(),
            );
            Solved {
                state,
                row,
                head: rel,
                eye_deg,
            }
        })
        .collect()
}

/// Draws, films and converts every frame, whole frames in parallel (one
/// worker per core, each frame on one worker, buffers reused), and pipes
/// them to the encoder in order from the calling thread. Each frame
/// depends only on its own state (and the previous frame's head for the
/// motion blur), so the output does not depend on the number of workers.
fn draw_frames(
    scene: &FaceScene,
    solved: &[Solved],
    look: &WebcamLook,
    sink: &mut (dyn FrameSink + Send),
) -> Result<()> {
    let (w, h) = (scene.width(), scene.height());
    let workers = std::thread::available_parallelism()
        .map_or(2, |n| n.get())
        .clamp(1, 16);
    std::thread::scope(|s| -> Result<()> {
        let mut frames_rx = Vec::with_capacity(workers);
        let mut spare_tx = Vec::with_capacity(workers);
        for first in 0..workers {
            let (tx, rx) = std::sync::mpsc::sync_channel::<Vec<u8>>(1);
            let (spare, spare_rx) = std::sync::mpsc::channel::<Vec<u8>>();
            frames_rx.push(rx);
            spare_tx.push(spare);
            s.spawn(move || {
                // Frames are the parallel unit: each worker runs its
                // frame's data-parallel steps (raster bands, backdrop rows,
                // webcam bands) in a pool of its own single thread, so they
                // cost no cross-thread scheduling or idle spinning.
                let Ok(pool) = rayon::ThreadPoolBuilder::new().num_threads(1).build() else {
                    return;
                };
                pool.install(move || {
                    let mut raster = Rasterizer::new(w, h);
                    let mut mesh = TexturedMesh::new(vec![], vec![], vec![]);
                    let mut frame = RgbImage::filled(w, h, [0, 0, 0]);
                    let mut webcam = Webcam::new(look, w, h);
                    for i in (first..solved.len()).step_by(workers) {
                        let st = &solved[i].state;
                        scene.draw(st, &mut raster, &mut mesh, &mut frame);
                        let nose = scene.nose_px(&st.head);
                        let motion = if i == 0 {
                            [0.0, 0.0]
                        } else {
                            let q = scene.nose_px(&solved[i - 1].state.head);
                            [(nose[0] - q[0]) as f32, (nose[1] - q[1]) as f32]
                        };
                        webcam.apply(&mut frame, i as u64, motion);
                        let mut yuv = spare_rx
                            .try_recv()
                            .unwrap_or_else(|_| vec![0u8; w * h * 3 / 2]);
                        rgb_to_yuv420(&frame.data, w, [0, 0, w, h], &mut yuv, w, h);
                        if tx.send(yuv).is_err() {
                            break; // the writer stopped on an error
                        }
                    }
                });
            });
        }
        for i in 0..solved.len() {
            let buf = frames_rx[i % workers].recv().map_err(|_| {
                eyereplay_render::RenderError::Input(format!("frame {i}: render worker stopped"))
            })?;
            sink.frame(i, &buf)?;
            let _ = spare_tx[i % workers].send(buf);
        }
        Ok(())
    })
}

fn write_head_csv(path: &Path, solved: &[Solved]) -> Result<()> {
    eyereplay_core::atomic_write_with(path, |w| {
        writeln!(w, "{HEAD_TRUTH_HEADER}")?;
        for (i, s) in solved.iter().enumerate() {
            let h = &s.head;
            writeln!(
                w,
                "{i},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4}",
                h.yaw_deg,
                h.pitch_deg,
                h.roll_deg,
                h.translation_cm[0],
                h.translation_cm[1],
                h.translation_cm[2],
                s.eye_deg.0,
                s.eye_deg.1,
                h.yaw_deg + s.eye_deg.0,
                h.pitch_deg + s.eye_deg.1,
            )?;
        }
        Ok(())
    })?;
    Ok(())
}

/// Renders a session of `scene` to `out_mp4`, with the truth CSV (the
/// close-up mode's layout, measured in this video's image) and the head
/// truth CSV ([`HEAD_TRUTH_HEADER`]). Nothing is left under the target
/// names on error.
pub fn render_face_session(
    scene: &FaceScene,
    traj: &[CanvasPos],
    blinks: Option<&[bool]>,
    p: &FaceSessionParams,
    out_mp4: &Path,
    out_truth_csv: &Path,
    out_head_csv: &Path,
) -> Result<FaceSessionStats> {
    let t0 = Instant::now();
    let (traj, clamped) = check_trajectory(traj, blinks, p.mapping.canvas)?;
    let (w, h) = (scene.width(), scene.height());
    let mut enc = p.encoder.clone();
    // 0 (the identity look): no rate control, the encoder's own CRF.
    enc.bitrate_kbps = Some(p.look.bitrate_kbps_for(w, h)).filter(|&k| k > 0);
    let mut encoder = Encoder::start(out_mp4, w, h, p.fps, &enc)?;
    let solved = solve_frames(scene, &traj, blinks, p);
    let t1 = Instant::now();
    draw_frames(scene, &solved, &p.look, &mut encoder)?;
    let render_s = t1.elapsed().as_secs_f64();
    let rows: Vec<TruthRow> = solved.iter().map(|s| s.row).collect();
    eyereplay_dataset::write_truth_csv(out_truth_csv, &rows)?;
    if let Err(e) = write_head_csv(out_head_csv, &solved) {
        let _ = std::fs::remove_file(out_truth_csv);
        return Err(e);
    }
    if let Err(e) = encoder.finish() {
        let _ = std::fs::remove_file(out_truth_csv);
        let _ = std::fs::remove_file(out_head_csv);
        return Err(e.into());
    }
    Ok(FaceSessionStats {
        frames: solved.len(),
        clamped_points: clamped,
        blink_frames: rows.iter().filter(|r| r.blink).count(),
        max_head_yaw_deg: solved
            .iter()
            .map(|s| s.head.yaw_deg.abs())
            .fold(0.0, f64::max),
        max_head_pitch_deg: solved
            .iter()
            .map(|s| s.head.pitch_deg.abs())
            .fold(0.0, f64::max),
        render_s,
        total_s: t0.elapsed().as_secs_f64(),
    })
}

/// Keeps every frame in memory (the bench's render-only pass).
struct Keep {
    frames: Vec<u8>,
    frame_bytes: usize,
}

impl FrameSink for Keep {
    fn frame(&mut self, i: usize, yuv: &[u8]) -> Result<(), eyereplay_render::RenderError> {
        let n = self.frame_bytes;
        self.frames[i * n..(i + 1) * n].copy_from_slice(yuv);
        Ok(())
    }
}

/// The full-face mode's speed, measured as the close-up's
/// ([`eyereplay_render::run_bench`]): render only (frames kept in memory),
/// encode only (the same frames, the look's bitrate), and end to end
/// through [`render_face_session`], on `traj`, in one run.
pub fn run_face_bench(
    scene: &FaceScene,
    traj: &[CanvasPos],
    p: &FaceSessionParams,
) -> Result<BenchReport> {
    let (w, h) = (scene.width(), scene.height());
    let n = traj.len();
    let dir = tempfile::tempdir().map_err(|source| crate::FaceError::Io {
        path: std::env::temp_dir(),
        source,
    })?;
    let (traj, _) = check_trajectory(traj, None, p.mapping.canvas)?;
    let solved = solve_frames(scene, &traj, None, p);
    let frame_bytes = w * h * 3 / 2;
    let mut keep = Keep {
        frames: vec![0u8; n * frame_bytes],
        frame_bytes,
    };
    let c0 = cpu_times();
    let t = Instant::now();
    draw_frames(scene, &solved, &p.look, &mut keep)?;
    let render_s = t.elapsed().as_secs_f64();
    let c1 = cpu_times();
    let mut enc = p.encoder.clone();
    // 0 (the identity look): no rate control, the encoder's own CRF.
    enc.bitrate_kbps = Some(p.look.bitrate_kbps_for(w, h)).filter(|&k| k > 0);
    let t = Instant::now();
    let mut encoder = Encoder::start(&dir.path().join("encode_only.mp4"), w, h, p.fps, &enc)?;
    for f in keep.frames.chunks(frame_bytes) {
        encoder.write_frame(f)?;
    }
    encoder.finish()?;
    let encode_s = t.elapsed().as_secs_f64();
    let c2 = cpu_times();
    drop(keep);
    let t = Instant::now();
    render_face_session(
        scene,
        &traj,
        None,
        p,
        &dir.path().join("s.mp4"),
        &dir.path().join("s_truth.csv"),
        &dir.path().join("s_head.csv"),
    )?;
    let e2e_s = t.elapsed().as_secs_f64();
    let c3 = cpu_times();
    let nf = n as f64;
    let ms = |a: Option<(f64, f64)>, b: Option<(f64, f64)>, pick: fn((f64, f64)) -> f64| {
        Some((pick(b?) - pick(a?)) * 1000.0 / nf)
    };
    let end_to_end_cpu_ms = ms(c2, c3, |c| c.0 + c.1);
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    Ok(BenchReport {
        frames: n,
        width: w,
        height: h,
        video_fps: p.fps,
        render_fps: nf / render_s,
        encode_fps: nf / encode_s,
        end_to_end_fps: nf / e2e_s,
        realtime_factor: nf / e2e_s / p.fps,
        ratio_to_encode: encode_s / e2e_s,
        scene_setup_s: 0.0,
        render_cpu_ms: ms(c0, c1, |c| c.0),
        encode_cpu_ms: ms(c1, c2, |c| c.0 + c.1),
        end_to_end_cpu_ms,
        cpu_bound_fps: end_to_end_cpu_ms.map(|m| cores as f64 * 1000.0 / m),
        cores,
    })
}
