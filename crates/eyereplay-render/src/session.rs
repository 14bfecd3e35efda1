//! Rendering one session: trajectory in, MP4 and ground-truth CSV out.

use crate::encode::{Encoder, EncoderSettings};
use crate::scene::{EyeTruth, Scene, Side};
use crate::{closure_track, GazeMapping, Identity, RenderError};
use eyereplay_core::{Canvas, CanvasPos};
use eyereplay_dataset::{EyeTruthRow, TruthRow};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::Path;
use std::sync::mpsc;
use std::time::Instant;

/// Everything that decides how a session looks.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RenderParams {
    /// Output video size (even numbers; need not match the canvas).
    pub width: usize,
    pub height: usize,
    pub fps: f64,
    pub identity: Identity,
    pub mapping: GazeMapping,
    /// Add blinks at the identity's natural rate where none are flagged.
    pub natural_blinks: bool,
    pub encoder: EncoderSettings,
}

/// The largest video side the renderers draw, in pixels.
pub const MAX_SIDE_PX: usize = 8192;

impl RenderParams {
    /// 1280x720 at 25 fps, default canvas and calibration, the given identity.
    pub fn new(identity: Identity) -> RenderParams {
        RenderParams {
            width: 1280,
            height: 720,
            fps: 25.0,
            identity,
            mapping: GazeMapping::new(Canvas::default()),
            natural_blinks: false,
            encoder: EncoderSettings::default(),
        }
    }

    pub fn validate(&self) -> Result<(), RenderError> {
        if self.width < 64 || self.height < 64 || (self.width | self.height) & 1 != 0 {
            return Err(RenderError::Params(format!(
                "video size must be even and at least 64x64, got {}x{}",
                self.width, self.height
            )));
        }
        // H.264's largest level (6.2) ends at 8192 px a side; past it the
        // encoder refuses, after the frame buffers of a huge frame were
        // allocated and drawn.
        if self.width > MAX_SIDE_PX || self.height > MAX_SIDE_PX {
            return Err(RenderError::Params(format!(
                "video size must be at most {MAX_SIDE_PX} px a side (H.264), got {}x{}",
                self.width, self.height
            )));
        }
        if !(self.fps.is_finite() && self.fps > 0.0 && self.fps <= 1000.0) {
            return Err(RenderError::Params(format!(
                "fps must be in (0, 1000], got {}",
                self.fps
            )));
        }
        self.encoder.validate()?;
        self.mapping.validate()
    }
}

/// Per-frame ground truth of a rendered session.
#[derive(Clone, Debug)]
pub struct FrameTruth {
    pub input: CanvasPos,
    /// Image-left eye, then image-right eye.
    pub eyes: [EyeTruth; 2],
    pub closure: f64,
    pub pupil_scale: f64,
}

impl FrameTruth {
    pub fn blink(&self) -> bool {
        self.closure >= 0.5
    }
}

#[derive(Clone, Debug, Default, Serialize)]
pub struct RenderStats {
    pub frames: usize,
    /// Input points outside the canvas, clamped onto its edge.
    pub clamped_points: usize,
    /// Frames with the lids at least half closed.
    pub blink_frames: usize,
    pub render_s: f64,
    pub total_s: f64,
    /// Where the eyes are in the image.
    pub eyes: Option<[crate::EyeGeometry; 2]>,
}

impl RenderStats {
    pub fn fps(&self) -> f64 {
        self.frames as f64 / self.total_s.max(1e-9)
    }
}

/// Checks a trajectory and clamps it onto the canvas; returns the number
/// of clamped points.
pub fn check_trajectory(
    traj: &[CanvasPos],
    blinks: Option<&[bool]>,
    canvas: Canvas,
) -> Result<(Vec<CanvasPos>, usize), RenderError> {
    if traj.is_empty() {
        return Err(RenderError::Input("trajectory has no frames".into()));
    }
    if let Some(b) = blinks {
        if b.len() != traj.len() {
            return Err(RenderError::Input(format!(
                "blink flags have {} frames, trajectory has {}",
                b.len(),
                traj.len()
            )));
        }
    }
    let [w, h] = canvas.extent();
    let mut clamped = 0;
    let mut out = Vec::with_capacity(traj.len());
    for (i, p) in traj.iter().enumerate() {
        if !p.x_px.is_finite() || !p.y_px.is_finite() {
            return Err(RenderError::Input(format!(
                "frame {i}: position ({}, {}) is not a finite number",
                p.x_px, p.y_px
            )));
        }
        let q = CanvasPos {
            x_px: p.x_px.clamp(0.0, w),
            y_px: p.y_px.clamp(0.0, h),
        };
        if q != *p {
            clamped += 1;
        }
        out.push(q);
    }
    Ok((out, clamped))
}

/// Solves both eyes and the lids for every frame (frames are independent,
/// so this runs in parallel and is still deterministic).
pub fn solve_truth(
    scene: &Scene,
    traj: &[CanvasPos],
    blinks: Option<&[bool]>,
    params: &RenderParams,
) -> Vec<FrameTruth> {
    let id = &params.identity;
    let closure = closure_track(
        traj.len(),
        params.fps,
        blinks,
        params.natural_blinks.then_some(id.blink_rate_per_min),
        id.seed,
    );
    let verg = params.mapping.vergence_rad(id.eye.ipd_mm);
    let mut rng = crate::rng::SplitMix64::new(id.seed ^ 0x9091);
    let (ph1, ph2) = (
        rng.range(0.0, std::f64::consts::TAU),
        rng.range(0.0, std::f64::consts::TAU),
    );
    traj.par_iter()
        .enumerate()
        .map(|(i, &c)| {
            let target = params.mapping.target_norm(c);
            let eyes = scene.solve_gaze(target, verg);
            let t = i as f64 / params.fps;
            // Slow pupil drift plus hippus; deterministic from the seed.
            let pupil_scale = 1.0
                + id.eye.pupil_variation
                    * (0.6 * (std::f64::consts::TAU * 0.05 * t + ph1).sin()
                        + 0.4 * (std::f64::consts::TAU * 0.23 * t + ph2).sin());
            FrameTruth {
                input: c,
                eyes: Side::BOTH.map(|side| scene.truth(side, eyes[side.index()], closure[i])),
                closure: closure[i],
                pupil_scale,
            }
        })
        .collect()
}

/// The truth CSV row of a rendered frame.
impl FrameTruth {
    pub fn row(&self, frame: usize) -> TruthRow {
        let eye = |e: &EyeTruth| EyeTruthRow {
            yaw_deg: e.pose.yaw_rad.to_degrees(),
            pitch_deg: e.pose.pitch_rad.to_degrees(),
            iris_px: e.iris_px,
            nx: e.norm.nx,
            ny: e.norm.ny,
            aperture: e.aperture,
        };
        TruthRow {
            frame: frame as u64,
            x_px: self.input.x_px,
            y_px: self.input.y_px,
            eyes: [eye(&self.eyes[0]), eye(&self.eyes[1])],
            lid_closure: self.closure,
            blink: self.blink(),
        }
    }
}

/// Writes the ground-truth CSV atomically (layout: [`eyereplay_dataset::TRUTH_HEADER`]).
pub fn write_truth_csv(path: &Path, truth: &[FrameTruth]) -> Result<(), RenderError> {
    let rows: Vec<TruthRow> = truth.iter().enumerate().map(|(i, t)| t.row(i)).collect();
    eyereplay_dataset::write_truth_csv(path, &rows)?;
    Ok(())
}

/// Where rendered frames go.
pub trait FrameSink {
    fn frame(&mut self, index: usize, yuv: &[u8]) -> Result<(), RenderError>;
}

/// Renders every frame's yuv420p image and hands them to `sink` in order
/// (through [`pipeline_frames`]).
pub fn render_frames(
    scene: &Scene,
    truth: &[FrameTruth],
    sink: &mut (dyn FrameSink + Send),
) -> Result<(), RenderError> {
    pipeline_frames(
        truth.len(),
        &|| scene.background_yuv().to_vec(),
        &|| (),
        &|_, i, buf| {
            let t = &truth[i];
            let poses = [t.eyes[0].pose, t.eyes[1].pose];
            scene.render_eyes_yuv_serial(poses, t.closure, t.pupil_scale, buf);
        },
        sink,
    )
}

/// Draws frames `0..frames` and hands them to `sink` in order: whole frames
/// in parallel, one worker thread per core, each frame on one worker
/// (splitting a frame's rows across threads left cores idle at every
/// frame's end), while the calling thread feeds the sink (the encoder's
/// pipe). Each worker makes its own state with `new_state` and its frame
/// buffers with `new_buffer` (they are reused: `draw(state, i, buffer)`
/// gets one that held an earlier frame of the same worker, or a new one),
/// and runs `draw` in a rayon pool of its own single thread, so data-
/// parallel steps inside a frame cost no cross-thread scheduling. Frames
/// that depend only on their index give output independent of the number
/// of workers.
pub fn pipeline_frames<S>(
    frames: usize,
    new_buffer: &(dyn Fn() -> Vec<u8> + Sync),
    new_state: &(dyn Fn() -> S + Sync),
    draw: &(dyn Fn(&mut S, usize, &mut [u8]) + Sync),
    sink: &mut (dyn FrameSink + Send),
) -> Result<(), RenderError> {
    let workers = std::thread::available_parallelism()
        .map_or(2, |n| n.get())
        .clamp(1, 16);
    std::thread::scope(|s| {
        let mut frames_rx = Vec::with_capacity(workers);
        let mut spare_tx = Vec::with_capacity(workers);
        for first in 0..workers {
            let (tx, rx) = mpsc::sync_channel::<Vec<u8>>(1);
            let (spare, spare_rx) = mpsc::channel::<Vec<u8>>();
            frames_rx.push(rx);
            spare_tx.push(spare);
            s.spawn(move || {
                let Ok(pool) = rayon::ThreadPoolBuilder::new().num_threads(1).build() else {
                    return; // the writer reports the stopped worker
                };
                pool.install(move || {
                    let mut state = new_state();
                    for i in (first..frames).step_by(workers) {
                        let mut buf = spare_rx.try_recv().unwrap_or_else(|_| new_buffer());
                        draw(&mut state, i, &mut buf);
                        if tx.send(buf).is_err() {
                            break; // the writer stopped on an error
                        }
                    }
                });
            });
        }
        for i in 0..frames {
            let buf = frames_rx[i % workers]
                .recv()
                .map_err(|_| RenderError::Input(format!("frame {i}: render worker stopped")))?;
            sink.frame(i, &buf)?;
            let _ = spare_tx[i % workers].send(buf);
        }
        Ok(())
    })
}

impl FrameSink for Encoder {
    fn frame(&mut self, _index: usize, yuv: &[u8]) -> Result<(), RenderError> {
        self.write_frame(yuv)
    }
}

/// Renders a session to an H.264 MP4 and a ground-truth CSV.
///
/// `traj` is in canvas pixels (one point per frame at `params.fps`);
/// `blinks`, when given, flags frames where the source blinked. Points off
/// the canvas are clamped (counted in the stats). Both outputs appear only
/// when complete: the video is encoded to a hidden temporary file and
/// renamed, the CSV is written atomically, and on error neither is left.
pub fn render_session(
    traj: &[CanvasPos],
    blinks: Option<&[bool]>,
    params: &RenderParams,
    out_mp4: &Path,
    out_truth_csv: &Path,
) -> Result<RenderStats, RenderError> {
    let t0 = Instant::now();
    params.validate()?;
    let (traj, clamped) = check_trajectory(traj, blinks, params.mapping.canvas)?;
    let mut encoder = Encoder::start(
        out_mp4,
        params.width,
        params.height,
        params.fps,
        &params.encoder,
    )?;
    let scene = Scene::new(&params.identity, params.width, params.height);
    let truth = solve_truth(&scene, &traj, blinks, params);
    let t1 = Instant::now();
    render_frames(&scene, &truth, &mut encoder)?;
    let render_s = t1.elapsed().as_secs_f64();
    write_truth_csv(out_truth_csv, &truth)?;
    if let Err(e) = encoder.finish() {
        let _ = std::fs::remove_file(out_truth_csv);
        return Err(e);
    }
    Ok(RenderStats {
        frames: truth.len(),
        clamped_points: clamped,
        blink_frames: truth.iter().filter(|t| t.blink()).count(),
        render_s,
        total_s: t0.elapsed().as_secs_f64(),
        eyes: Some(scene.geometry()),
    })
}

/// Renders a session's frames as PNG files `frame_000000.png`... into
/// `dir` (the lossless stills option), plus the ground-truth CSV.
pub fn render_session_pngs(
    traj: &[CanvasPos],
    blinks: Option<&[bool]>,
    params: &RenderParams,
    dir: &Path,
    out_truth_csv: &Path,
) -> Result<RenderStats, RenderError> {
    let t0 = Instant::now();
    params.validate()?;
    let (traj, clamped) = check_trajectory(traj, blinks, params.mapping.canvas)?;
    std::fs::create_dir_all(dir).map_err(|e| RenderError::io(dir, e))?;
    let scene = Scene::new(&params.identity, params.width, params.height);
    let truth = solve_truth(&scene, &traj, blinks, params);
    let mut rgb = scene.background_rgb().to_vec();
    let mut scratch = Vec::new();
    for (i, t) in truth.iter().enumerate() {
        let poses = [t.eyes[0].pose, t.eyes[1].pose];
        scene.render_eyes(
            poses,
            t.closure,
            t.pupil_scale,
            Some(&mut rgb),
            None,
            &mut scratch,
        );
        crate::write_png(
            &dir.join(format!("frame_{i:06}.png")),
            &rgb,
            params.width,
            params.height,
        )?;
    }
    write_truth_csv(out_truth_csv, &truth)?;
    Ok(RenderStats {
        frames: truth.len(),
        clamped_points: clamped,
        blink_frames: truth.iter().filter(|t| t.blink()).count(),
        render_s: t0.elapsed().as_secs_f64(),
        total_s: t0.elapsed().as_secs_f64(),
        eyes: Some(scene.geometry()),
    })
}
