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
//!
//! The read-back match draws a session twice, the second time with other
//! eyes only: the first pass keeps its frames
//! ([`render_face_session_every_kept`]) and the second redraws just the
//! rows around the eyes on them ([`render_face_session_over`]), the same
//! bytes as drawing them whole.

use crate::coordination::{head_track, CoordinationParams, HeadDynamics, Sway, Task};
use crate::error::Result;
use crate::pose::HeadPose;
use crate::raster::{Rasterizer, RgbImage, TexturedMesh};
use crate::scene::{FaceScene, FaceState};
use crate::webcam::{Webcam, WebcamLook};
use eyereplay_core::profile::lap;
use eyereplay_core::{CanvasPos, NormPos};
use eyereplay_dataset::{EyeTruthRow, TruthRow};
use eyereplay_render::{
    check_trajectory, closure_track, cpu_times, pipeline_frames, rgb_to_yuv420, time_bench,
    BenchReport, BenchShape, Encoder, EncoderSettings, FrameSink, GazeMapping, RenderError,
    SecondPassBench,
};
use rayon::prelude::*;
use serde::Serialize;
use std::ops::Range;
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};
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
/// Roll limit for a head driven by a source video (`source_head`): a head
/// tilted onto a shoulder would take the photo's face past what its
/// backdrop can follow.
pub const HEAD_ROLL_LIMIT_DEG: f64 = 10.0;

/// What a session varies besides the identity.
#[derive(Clone, Debug)]
pub struct FaceSessionParams {
    pub fps: f64,
    pub mapping: GazeMapping,
    pub natural_blinks: bool,
    pub blink_rate_per_min: f64,
    pub task: Task,
    /// Frames in which the person reads (an interview's per-frame labels):
    /// the head moves as in [`Task::Reading`] there and as in `task`
    /// elsewhere. `None`: `task` throughout.
    pub reading_frames: Option<Vec<bool>>,
    pub coordination: CoordinationParams,
    pub dynamics: HeadDynamics,
    /// RMS of the drift and sway: yaw, pitch, roll (deg), x, y, z (cm).
    pub sway_rms: [f64; 6],
    pub look: WebcamLook,
    pub encoder: EncoderSettings,
    pub seed: u64,
    /// How the extractor's reading moves as the head turns, in measured
    /// units per degree of yaw and pitch (see [`crate::match_extractor`]);
    /// subtracted per frame. `None`: no correction.
    pub pose_slopes: Option<[[f64; 2]; 2]>,
    /// The head per frame from a source video (relative to its rest pose,
    /// [`crate::SourceHeadTrack`]): its rotation replaces the coordination
    /// model's and the sway's, clamped to the mode's limits; frames with
    /// `None` (or beyond its end) use the model. Its translation is not
    /// used: the photo's body and room are a still backdrop, and a source
    /// leaning in or out by centimetres would scale the head alone against
    /// them (it looked like a head floating over a still body); the sway's
    /// small drift moves the head instead.
    pub source_head: Option<Vec<Option<HeadPose>>>,
    /// A head path to draw instead of planning one: per frame the head
    /// relative to the rest pose and whether it came from the source video,
    /// as an earlier render of the same session returned it
    /// ([`FaceSessionStats::head_path`]). The read-back match
    /// (`render.match_readback`) draws its second pass with the first
    /// pass's head, so that only the eye differs between the video it
    /// measured and the one it draws. It must have the trajectory's
    /// frames: [`render_face_session`] refuses another length.
    pub head_path: Option<Vec<(HeadPose, bool)>>,
}

/// What one frame of a rendered session drew, for fitting how the
/// extractor read the video ([`crate::refine_match`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DrawnFrame {
    /// The eye position handed to the scene, in drawn units: the target
    /// through the response map and the head-pose correction.
    pub drawn: NormPos,
    /// The head relative to the rest pose.
    pub head: HeadPose,
    /// The head came from the source video.
    pub from_source: bool,
    /// The lids are closed at least half way (the truth CSV's `blink`).
    pub blink: bool,
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
    /// Frames whose head came from the source video.
    pub source_head_frames: usize,
    pub render_s: f64,
    pub total_s: f64,
    /// Per frame drawn, what was drawn.
    #[serde(skip)]
    pub drawn: Vec<DrawnFrame>,
    /// The head of every frame of the session, drawn or not
    /// ([`render_face_session_every`]), for [`FaceSessionParams::head_path`]:
    /// drawing the session again with the same head.
    #[serde(skip)]
    pub head_path: Vec<(HeadPose, bool)>,
    /// Frames drawn over an earlier pass's kept image, only their rows
    /// around the eyes redrawn ([`render_face_session_over`]).
    #[serde(skip)]
    pub frames_over_kept: usize,
}

/// How much of a first pass's drawn frames [`render_face_session_every_kept`]
/// keeps for the second pass at most, per session (bytes of yuv420p): the
/// default's 30-s sessions at 640x480 keep all 375 of theirs in 173 MB;
/// a longer or larger session keeps its first frames up to this, and the
/// second pass draws the rest whole.
pub const KEEP_FRAMES_BUDGET_BYTES: usize = 512 << 20;

/// The frames a pass drew, kept for a later pass of the same session that
/// differs from it in the eyes only ([`render_face_session_over`]): per
/// frame drawn, its state and its yuv420p image as handed to the encoder.
pub struct KeptFrames {
    step: usize,
    states: Vec<FaceState>,
    /// The first drawn frames' images (the budget may stop short of all).
    yuv: Vec<Vec<u8>>,
}

impl KeptFrames {
    /// Frames whose image is kept.
    pub fn frames(&self) -> usize {
        self.yuv.len()
    }

    /// The pass drew every `step`-th frame of the session.
    pub fn step(&self) -> usize {
        self.step
    }

    /// The kept image and state of session frame `i`, if that pass drew
    /// and kept it.
    fn at(&self, i: usize) -> Option<(&FaceState, &[u8])> {
        if !i.is_multiple_of(self.step) {
            return None;
        }
        let j = i / self.step;
        Some((self.states.get(j)?, self.yuv.get(j)?))
    }
}

/// A frame sink that hands frames on and keeps copies of the first
/// `max` of them.
struct Keeping<'a> {
    sink: &'a mut (dyn FrameSink + Send),
    kept: Vec<Vec<u8>>,
    max: usize,
}

impl FrameSink for Keeping<'_> {
    fn frame(&mut self, index: usize, yuv: &[u8]) -> std::result::Result<(), RenderError> {
        if self.kept.len() < self.max {
            self.kept.push(yuv.to_vec());
        }
        self.sink.frame(index, yuv)
    }
}

/// One frame's state and truth.
struct Solved {
    state: FaceState,
    row: TruthRow,
    /// The head relative to the rest pose, and the mean eye-in-head angles.
    head: HeadPose,
    eye_deg: (f64, f64),
    /// The head came from the source video.
    from_source: bool,
    /// The eye position handed to the scene (drawn units).
    drawn: NormPos,
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

/// The head per frame of a session, relative to the rest pose, and whether
/// it came from the source video: the eye-head coordination model's share
/// of each gaze shift plus drift and sway, or the source's own pose
/// (`p.source_head`), clamped to the mode's limits. The gaze is solved from
/// `p.mapping`'s targets, so a caller may plan the head before the
/// extractor's response is known (the probe centres its head path on it).
pub fn head_path(
    scene: &FaceScene,
    traj: &[CanvasPos],
    p: &FaceSessionParams,
) -> Vec<(HeadPose, bool)> {
    head_path_of(scene, &targets_of(traj, p), p)
}

/// Each frame's gaze target `(nx, ny)` through `p.mapping`.
fn targets_of(traj: &[CanvasPos], p: &FaceSessionParams) -> Vec<(f64, f64)> {
    traj.iter()
        .map(|&c| {
            let t = p.mapping.target_norm(c);
            (t.nx, t.ny)
        })
        .collect()
}

fn head_path_of(
    scene: &FaceScene,
    targets: &[(f64, f64)],
    p: &FaceSessionParams,
) -> Vec<(HeadPose, bool)> {
    let n = targets.len();
    if let Some(path) = &p.head_path {
        return path.iter().copied().take(n).collect();
    }
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
    let tasks: Vec<Task> = (0..n)
        .map(|i| match &p.reading_frames {
            Some(r) if r.get(i).copied().unwrap_or(false) => Task::Reading,
            _ => p.task,
        })
        .collect();
    let gaze: Vec<(f64, f64)> = eye_rest
        .iter()
        .zip(&tasks)
        .map(|(&(eh, ev), &task)| {
            let h = gaze_for_eye(eh, |g| g - c.head_target(task, g, 0.0).0);
            let v = gaze_for_eye(ev, |g| g - c.head_target(task, 0.0, g).1);
            (h, v)
        })
        .collect();
    let track = head_track(&c, &p.dynamics, &tasks, &gaze, 1.0 / p.fps);
    let sway = Sway::new(p.seed ^ 0x5ea7, p.sway_rms);
    (0..n)
        .into_par_iter()
        .map(|i| {
            let source = p
                .source_head
                .as_ref()
                .and_then(|h| h.get(i).copied().flatten());
            let s = sway.at(i as f64 / p.fps);
            let rel = match source {
                Some(src) => HeadPose {
                    yaw_deg: src.yaw_deg.clamp(-HEAD_YAW_LIMIT_DEG, HEAD_YAW_LIMIT_DEG),
                    pitch_deg: src
                        .pitch_deg
                        .clamp(-HEAD_PITCH_LIMIT_DEG, HEAD_PITCH_LIMIT_DEG),
                    roll_deg: src
                        .roll_deg
                        .clamp(-HEAD_ROLL_LIMIT_DEG, HEAD_ROLL_LIMIT_DEG),
                    translation_cm: [s[3], s[4], s[5]],
                },
                None => {
                    let (hh, hv) = track.head_deg[i];
                    HeadPose {
                        yaw_deg: (hh + s[0]).clamp(-HEAD_YAW_LIMIT_DEG, HEAD_YAW_LIMIT_DEG),
                        pitch_deg: (hv + s[1]).clamp(-HEAD_PITCH_LIMIT_DEG, HEAD_PITCH_LIMIT_DEG),
                        roll_deg: s[2],
                        translation_cm: [s[3], s[4], s[5]],
                    }
                }
            };
            (rel, source.is_some())
        })
        .collect()
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
    let targets = targets_of(traj, p);
    let heads = head_path_of(scene, &targets, p);
    let rest = scene.rest_pose;
    (0..n)
        .into_par_iter()
        .map(|i| {
            let (rel, from_source) = heads[i];
            let head = HeadPose {
                yaw_deg: rest.yaw_deg + rel.yaw_deg,
                pitch_deg: rest.pitch_deg + rel.pitch_deg,
                roll_deg: rest.roll_deg + rel.roll_deg,
                translation_cm: std::array::from_fn(|k| {
                    rest.translation_cm[k] + rel.translation_cm[k]
                }),
            };
            // The extractor reads a turned head's eye a little off: draw
            // against that, in drawn units (through the response map).
            let mut target = targets[i];
            if let Some(sl) = p.pose_slopes {
                // The slopes are in measured units: the reading moves by
                // S (yaw, pitch); drawing A^-1 S (yaw, pitch) less cancels it.
                let shift = [0, 1].map(|k| sl[k][0] * rel.yaw_deg + sl[k][1] * rel.pitch_deg);
                let [dx, dy] = p
                    .mapping
                    .extractor_response
                    .map_or(shift, |m| m.solve_linear(shift));
                target.0 -= dx;
                target.1 -= dy;
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
                from_source,
                drawn: NormPos {
                    nx: target.0,
                    ny: target.1,
                },
            }
        })
        .collect()
}

/// Draws, films and converts every `step`-th frame (in parallel by whole
/// frames, [`pipeline_frames`]) and hands them to `sink` in order. Each
/// frame depends only on its own state (and the previous frame's head for
/// the motion blur, the previous of the session, drawn or not), so the
/// output does not depend on the number of workers, and a frame drawn at
/// a step of 2 is the same frame as at a step of 1. A frame `over` kept
/// (an earlier pass drew it, with other eyes) is that pass's image with
/// the rows around the eyes drawn again ([`Painter::draw_over`]); returns how
/// many.
fn draw_frames(
    scene: &FaceScene,
    solved: &[Solved],
    step: usize,
    look: &WebcamLook,
    over: Option<&KeptFrames>,
    sink: &mut (dyn FrameSink + Send),
) -> Result<usize> {
    let (w, h) = (scene.width(), scene.height());
    let reused = AtomicUsize::new(0);
    pipeline_frames(
        solved.len().div_ceil(step),
        &|| vec![0u8; w * h * 3 / 2],
        &|| Painter::new(scene, look),
        &|painter, j, yuv| {
            let i = j * step;
            let st = &solved[i].state;
            let frame = FrameAt {
                i,
                motion: motion_px(scene, solved, i),
            };
            if let Some(kept) = over.and_then(|k| k.at(i)) {
                if painter.draw_over(scene, frame, st, kept, yuv) {
                    reused.fetch_add(1, Ordering::Relaxed);
                    return;
                }
            }
            painter.draw(scene, frame, st, yuv);
        },
        sink,
    )?;
    Ok(reused.into_inner())
}

/// How far the image moved into session frame `i` from the frame before
/// (its nose, px; the motion blur's smear), drawn or not.
fn motion_px(scene: &FaceScene, solved: &[Solved], i: usize) -> [f32; 2] {
    let Some(prev) = i.checked_sub(1) else {
        return [0.0, 0.0];
    };
    let (p, q) = (
        scene.nose_px(&solved[i].state.head),
        scene.nose_px(&solved[prev].state.head),
    );
    [(p[0] - q[0]) as f32, (p[1] - q[1]) as f32]
}

/// Which frame of the session is drawn: its index (the noise's key) and
/// the image motion since the frame before (the motion blur's).
#[derive(Clone, Copy)]
struct FrameAt {
    i: usize,
    motion: [f32; 2],
}

/// One drawing worker's buffers for frames of one scene and look.
struct Painter {
    raster: Rasterizer,
    mesh: TexturedMesh,
    frame: RgbImage,
    webcam: Webcam,
}

impl Painter {
    fn new(scene: &FaceScene, look: &WebcamLook) -> Painter {
        let (w, h) = (scene.width(), scene.height());
        Painter {
            raster: Rasterizer::new(w, h),
            mesh: TexturedMesh::new(vec![], vec![], vec![]),
            frame: RgbImage::filled(w, h, [0, 0, 0]),
            webcam: Webcam::new(look, w, h),
        }
    }

    /// Frame `state` drawn whole, given the look, into `yuv`.
    fn draw(&mut self, scene: &FaceScene, at: FrameAt, state: &FaceState, yuv: &mut [u8]) {
        let (w, h) = (scene.width(), scene.height());
        scene.draw(state, &mut self.raster, &mut self.mesh, &mut self.frame);
        self.webcam.apply(&mut self.frame, at.i as u64, at.motion);
        rgb_to_yuv420(&self.frame.data, w, [0, 0, w, h], yuv, w, h);
    }

    /// Frame `state` into `yuv` from `kept`, the image of the same frame
    /// drawn in another state (same head, lids' closure and pupil; other
    /// eyes): that image with only [`strip_rows`]' rows drawn again, given
    /// the look and converted. The bytes are those of [`Painter::draw`]
    /// (each stage computes those rows as the whole frame does). False,
    /// `yuv` untouched, where the strip is not worth it or the states
    /// differ in more than the eyes: then the caller draws the frame whole.
    fn draw_over(
        &mut self,
        scene: &FaceScene,
        at: FrameAt,
        state: &FaceState,
        (before, image): (&FaceState, &[u8]),
        yuv: &mut [u8],
    ) -> bool {
        if image.len() != yuv.len() {
            return false;
        }
        let reach = self.webcam.reach_rows(at.motion);
        let Some((out, input)) = strip_rows(scene, before, state, reach) else {
            return false;
        };
        yuv.copy_from_slice(image);
        if out.is_empty() {
            return true;
        }
        let (w, h) = (scene.width(), scene.height());
        scene.draw_rows(
            state,
            &mut self.raster,
            &mut self.mesh,
            &mut self.frame,
            input,
        );
        self.webcam
            .apply_rows(&mut self.frame, at.i as u64, at.motion, out.clone());
        rgb_to_yuv420(&self.frame.data, w, [0, out.start, w, out.end], yuv, w, h);
        true
    }
}

/// Where a frame drawn in `state` is redrawn over its image drawn in
/// `before` ([`Painter::draw_over`]): the output rows the eyes' change
/// reaches through a look that reads `reach` rows each way, in whole
/// pairs (a chroma row is two image rows), and the input rows those read.
/// `None` where the states differ in more than the eyes
/// ([`FaceScene::rows_changed_by_eyes`]) or the input would be over half
/// the frame (drawing it whole is then as cheap); both empty where the
/// two draw alike.
fn strip_rows(
    scene: &FaceScene,
    before: &FaceState,
    state: &FaceState,
    reach: usize,
) -> Option<(Range<usize>, Range<usize>)> {
    let changed = scene.rows_changed_by_eyes(before, state)?;
    if changed.is_empty() {
        return Some((0..0, 0..0));
    }
    let h = scene.height();
    let a = changed.start.saturating_sub(reach) & !1;
    let b = ((changed.end + reach).min(h) + 1) & !1;
    let out = a..b.min(h);
    let input = out.start.saturating_sub(reach)..(out.end + reach).min(h);
    (2 * input.len() <= h).then_some((out, input))
}

fn write_head_csv(path: &Path, solved: &[Solved]) -> Result<()> {
    eyereplay_core::atomic_write_with(path, |w| {
        writeln!(w, "{HEAD_TRUTH_HEADER}")?;
        for s in solved {
            let i = s.row.frame;
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
    render_face_session_every(
        scene,
        traj,
        blinks,
        p,
        1,
        [out_mp4, out_truth_csv, out_head_csv],
    )
}

/// [`render_face_session`] drawing only every `step`-th frame (0, step,
/// 2 step, ...), at `p.fps / step`: the frames it draws are the full
/// session's frames, bit for bit before the encoder (the session is solved
/// at its own rate: head, blinks, motion blur), and the truth CSVs and
/// [`FaceSessionStats::drawn`] hold those frames only (the truth CSV's
/// `frame` column keeps the session's numbering). The read-back match's
/// first pass draws this way: its fit needs the session's fixations, not
/// every frame of each (docs/PERFORMANCE.md).
pub fn render_face_session_every(
    scene: &FaceScene,
    traj: &[CanvasPos],
    blinks: Option<&[bool]>,
    p: &FaceSessionParams,
    step: usize,
    files: [&Path; 3],
) -> Result<FaceSessionStats> {
    Ok(render(scene, traj, blinks, p, step, files, 0, None)?.0)
}

/// [`render_face_session_every`] keeping the frames it draws, up to
/// `budget_bytes` of them, for [`render_face_session_over`].
pub fn render_face_session_every_kept(
    scene: &FaceScene,
    traj: &[CanvasPos],
    blinks: Option<&[bool]>,
    p: &FaceSessionParams,
    step: usize,
    files: [&Path; 3],
    budget_bytes: usize,
) -> Result<(FaceSessionStats, KeptFrames)> {
    render(scene, traj, blinks, p, step, files, budget_bytes, None)
}

/// [`render_face_session`] over the frames an earlier pass of the same
/// session drew and kept ([`render_face_session_every_kept`]): where a
/// frame's head, lids' closure and pupil are that pass's (the read-back
/// match's second pass, drawn with the first pass's head path, differs in
/// its eyes only), its kept image gets only the rows around the eyes drawn
/// again; every other frame is drawn whole. The output is the same, byte
/// for byte, as [`render_face_session`]'s (a test compares them); it is
/// cheaper (docs/PERFORMANCE.md).
pub fn render_face_session_over(
    scene: &FaceScene,
    traj: &[CanvasPos],
    blinks: Option<&[bool]>,
    p: &FaceSessionParams,
    files: [&Path; 3],
    kept: &KeptFrames,
) -> Result<FaceSessionStats> {
    Ok(render(scene, traj, blinks, p, 1, files, 0, Some(kept))?.0)
}

/// A session's render: every `step`-th frame drawn (over `over`'s kept
/// frames where it has them), the first `keep_bytes` of them kept.
#[allow(clippy::too_many_arguments)]
fn render(
    scene: &FaceScene,
    traj: &[CanvasPos],
    blinks: Option<&[bool]>,
    p: &FaceSessionParams,
    step: usize,
    [out_mp4, out_truth_csv, out_head_csv]: [&Path; 3],
    keep_bytes: usize,
    over: Option<&KeptFrames>,
) -> Result<(FaceSessionStats, KeptFrames)> {
    if step == 0 {
        return Err(
            eyereplay_render::RenderError::Params("frame step must be at least 1".into()).into(),
        );
    }
    let t0 = Instant::now();
    let (traj, clamped) = check_trajectory(traj, blinks, p.mapping.canvas)?;
    if let Some(path) = p.head_path.as_ref().filter(|h| h.len() != traj.len()) {
        return Err(eyereplay_render::RenderError::Input(format!(
            "the given head path has {} frames, the trajectory {}",
            path.len(),
            traj.len()
        ))
        .into());
    }
    let enc = session_encoder(scene, p);
    let mut encoder = Encoder::start(
        out_mp4,
        scene.width(),
        scene.height(),
        p.fps / step as f64,
        &enc,
    )?;
    let solved = lap("solve head and eyes", || {
        solve_frames(scene, &traj, blinks, p)
    });
    let t1 = Instant::now();
    let frame_bytes = scene.width() * scene.height() * 3 / 2;
    let mut keeping = Keeping {
        sink: &mut encoder,
        kept: vec![],
        max: keep_bytes / frame_bytes.max(1),
    };
    let frames_over_kept = lap("draw frames", || {
        draw_frames(scene, &solved, step, &p.look, over, &mut keeping)
    })?;
    let kept_yuv = std::mem::take(&mut keeping.kept);
    let render_s = t1.elapsed().as_secs_f64();
    let head_path = solved.iter().map(|s| (s.head, s.from_source)).collect();
    // From here on, the frames drawn.
    let solved: Vec<Solved> = solved.into_iter().step_by(step).collect();
    let rows: Vec<TruthRow> = solved.iter().map(|s| s.row).collect();
    eyereplay_dataset::write_truth_csv(out_truth_csv, &rows)?;
    if let Err(e) = write_head_csv(out_head_csv, &solved) {
        let _ = std::fs::remove_file(out_truth_csv);
        return Err(e);
    }
    // The encoder runs beside the drawing; its CPU time is counted when
    // it is waited for, here.
    if let Err(e) = lap("x264 encode (ffmpeg process)", || encoder.finish()) {
        let _ = std::fs::remove_file(out_truth_csv);
        let _ = std::fs::remove_file(out_head_csv);
        return Err(e.into());
    }
    let kept = KeptFrames {
        step,
        states: solved.iter().map(|s| s.state).collect(),
        yuv: kept_yuv,
    };
    let stats = FaceSessionStats {
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
        source_head_frames: solved.iter().filter(|s| s.from_source).count(),
        render_s,
        total_s: t0.elapsed().as_secs_f64(),
        drawn: solved
            .iter()
            .map(|s| DrawnFrame {
                drawn: s.drawn,
                head: s.head,
                from_source: s.from_source,
                blink: s.row.blink,
            })
            .collect(),
        head_path,
        frames_over_kept,
    };
    Ok((stats, kept))
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
    let (traj, _) = check_trajectory(traj, None, p.mapping.canvas)?;
    let solved = solve_frames(scene, &traj, None, p);
    let shape = BenchShape {
        frames: traj.len(),
        width: scene.width(),
        height: scene.height(),
        fps: p.fps,
    };
    let mut report = time_bench(
        shape,
        &session_encoder(scene, p),
        0.0,
        |keep| draw_frames(scene, &solved, 1, &p.look, None, keep).map(|_| ()),
        |dir| {
            render_face_session(
                scene,
                &traj,
                None,
                p,
                &dir.join("s.mp4"),
                &dir.join("s_truth.csv"),
                &dir.join("s_head.csv"),
            )
            .map(|_| ())
        },
    )?;
    report.second_pass = second_pass_bench(scene, &traj, p, &solved)?;
    Ok(report)
}

/// A frame sink that drops the frames (drawing timed alone).
struct Discard;

impl FrameSink for Discard {
    fn frame(&mut self, _: usize, _: &[u8]) -> std::result::Result<(), RenderError> {
        Ok(())
    }
}

/// The read-back match's second pass, timed on the bench's session: its
/// frames (`first`) drawn every other one and kept, as the first pass does
/// (as many as [`KEEP_FRAMES_BUDGET_BYTES`] holds, from the start), then a
/// second pass with the same head and the eyes drawn 1.5x as far from the
/// middle, drawn whole and over the kept frames; CPU time of this process
/// per frame of each (drawing, look and conversion; no encoder).
fn second_pass_bench(
    scene: &FaceScene,
    traj: &[CanvasPos],
    p: &FaceSessionParams,
    first: &[Solved],
) -> Result<Option<SecondPassBench>> {
    let frame_bytes = scene.width() * scene.height() * 3 / 2;
    let n = first
        .len()
        .min(2 * (KEEP_FRAMES_BUDGET_BYTES / frame_bytes.max(1)));
    let first = &first[..n];
    let mut second_p = p.clone();
    second_p.mapping.extractor_response = Some(eyereplay_render::ResponseMap {
        a: [[2.0 / 3.0, 0.0], [0.0, 2.0 / 3.0]],
        b: [1.0 / 6.0, 1.0 / 6.0],
    });
    second_p.head_path = Some(first.iter().map(|s| (s.head, s.from_source)).collect());
    let second = solve_frames(scene, &traj[..n], None, &second_p);
    let mut discard = Discard;
    let mut keeping = Keeping {
        sink: &mut discard,
        kept: vec![],
        max: usize::MAX,
    };
    draw_frames(scene, first, 2, &p.look, None, &mut keeping)?;
    let kept = KeptFrames {
        step: 2,
        states: first.iter().step_by(2).map(|s| s.state).collect(),
        yuv: keeping.kept,
    };
    let cpu_ms = |over: Option<&KeptFrames>| -> Result<Option<f64>> {
        let c0 = cpu_times();
        draw_frames(scene, &second, 1, &p.look, over, &mut Discard)?;
        let c1 = cpu_times();
        Ok(c0.zip(c1).map(|(a, b)| (b.0 - a.0) * 1000.0 / n as f64))
    };
    let whole = cpu_ms(None)?;
    let over = cpu_ms(Some(&kept))?;
    // The rows the kept frames have redrawn (a frame drawn whole instead:
    // all of them), over all their rows.
    let webcam = Webcam::new(&p.look, scene.width(), scene.height());
    let rows: usize = (0..n)
        .step_by(2)
        .map(|i| {
            let reach = webcam.reach_rows(motion_px(scene, &second, i));
            strip_rows(scene, &first[i].state, &second[i].state, reach)
                .map_or(scene.height(), |(_, input)| input.len())
        })
        .sum();
    let strip_frac = rows as f64 / (n.div_ceil(2) * scene.height()).max(1) as f64;
    Ok(whole
        .zip(over)
        .map(|(whole_cpu_ms, over_kept_cpu_ms)| SecondPassBench {
            frames: n,
            whole_cpu_ms,
            over_kept_cpu_ms,
            strip_frac,
        }))
}

/// The session's encoder: the params' with the look's video-call bitrate
/// (none for the identity look, bitrate 0: then the encoder's CRF), and
/// x264 on one thread under that bitrate cap: its rate control (VBV) with
/// several threads gave different bytes from run to run (the same raw
/// frames piped twice, measured here), and the frames are drawn on all
/// cores anyway.
fn session_encoder(scene: &FaceScene, p: &FaceSessionParams) -> EncoderSettings {
    let mut enc = p.encoder.clone();
    enc.bitrate_kbps =
        Some(p.look.bitrate_kbps_for(scene.width(), scene.height())).filter(|&k| k > 0);
    if enc.bitrate_kbps.is_some() {
        enc.threads = Some(1);
    }
    enc
}
