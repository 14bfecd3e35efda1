//! The speed benchmark: render only, encode only, and end to end, measured
//! in one run on the same frames so the ratios mean something.

use crate::encode::{Encoder, EncoderSettings};
use crate::scene::Scene;
use crate::session::{render_frames, render_session, solve_truth, FrameSink, RenderParams};
use crate::RenderError;
use eyereplay_core::CanvasPos;
use serde::Serialize;
use std::time::Instant;

#[derive(Clone, Debug, Serialize)]
pub struct BenchReport {
    pub frames: usize,
    pub width: usize,
    pub height: usize,
    pub video_fps: f64,
    /// Frames per second rendering yuv420p frames, no encoder.
    pub render_fps: f64,
    /// Frames per second of the encoder alone, fed pre-rendered frames.
    pub encode_fps: f64,
    /// Frames per second end to end (render + encode + ground truth).
    pub end_to_end_fps: f64,
    /// End-to-end speed over real time.
    pub realtime_factor: f64,
    /// End-to-end speed over encode-only speed (1.0 = rendering is free).
    pub ratio_to_encode: f64,
    pub scene_setup_s: f64,
    /// CPU milliseconds per frame (all threads) of rendering, of the
    /// encoder, and of the whole end-to-end run including ffmpeg. Unlike
    /// frames/s these do not change when other work shares the machine.
    pub render_cpu_ms: Option<f64>,
    pub encode_cpu_ms: Option<f64>,
    pub end_to_end_cpu_ms: Option<f64>,
    /// Frames/s the end-to-end CPU cost allows on the machine's cores if
    /// nothing else runs: cores * 1000 / end_to_end_cpu_ms.
    pub cpu_bound_fps: Option<f64>,
    pub cores: usize,
    /// The full-face mode's read-back match: its second pass drawn whole
    /// and over a first pass's kept frames (`None` for other renderers,
    /// and where CPU time cannot be read).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub second_pass: Option<SecondPassBench>,
}

/// A second pass that differs from its first in the eyes only, drawn whole
/// and over the first pass's kept frames (every other frame kept, as the
/// read-back match draws them): CPU milliseconds per frame of each,
/// drawing, look and conversion only (no encoder).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct SecondPassBench {
    pub frames: usize,
    pub whole_cpu_ms: f64,
    pub over_kept_cpu_ms: f64,
    /// The rows drawn again on the kept frames, over all their rows.
    pub strip_frac: f64,
}

impl std::fmt::Display for BenchReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "{} frames {}x{} @ {} fps",
            self.frames, self.width, self.height, self.video_fps
        )?;
        writeln!(
            f,
            "scene setup      {:8.3} s (once per session)",
            self.scene_setup_s
        )?;
        writeln!(f, "render only      {:8.1} frames/s", self.render_fps)?;
        writeln!(f, "encode only      {:8.1} frames/s", self.encode_fps)?;
        writeln!(f, "end to end       {:8.1} frames/s", self.end_to_end_fps)?;
        writeln!(f, "real-time factor {:8.2} x", self.realtime_factor)?;
        write!(f, "ratio to encode  {:8.2}", self.ratio_to_encode)?;
        if let (Some(r), Some(e), Some(t), Some(b)) = (
            self.render_cpu_ms,
            self.encode_cpu_ms,
            self.end_to_end_cpu_ms,
            self.cpu_bound_fps,
        ) {
            write!(
                f,
                "\nCPU per frame    render {r:.2} ms, encode {e:.2} ms, end to end {t:.2} ms\n\
                 CPU-bound limit  {b:8.1} frames/s ({:.2}x real time) on {} cores",
                b / self.video_fps,
                self.cores
            )?;
        }
        if let Some(sp) = self.second_pass {
            write!(
                f,
                "\nsecond pass      {:.2} ms CPU per frame over the first pass's kept frames, \
                 {:.2} drawn whole = {:.2}x (the read-back match's; drawing only, {} frames; \
                 {:.0} % of the kept frames' rows drawn again)",
                sp.over_kept_cpu_ms,
                sp.whole_cpu_ms,
                sp.over_kept_cpu_ms / sp.whole_cpu_ms,
                sp.frames,
                100.0 * sp.strip_frac
            )?;
        }
        Ok(())
    }
}

/// A reading-like trajectory: left-to-right sweeps over 8 % of the canvas
/// width with return sweeps and line steps, plus small fixation jitter.
pub fn reading_trajectory(frames: usize, width: f64, height: f64) -> Vec<CanvasPos> {
    let span = 0.08 * width;
    let x0 = width / 2.0 - span / 2.0;
    (0..frames)
        .map(|i| {
            let line = i / 60;
            let k = i % 60;
            // 50 frames of stepwise progress (fixations), 10 frames return.
            let x = if k < 50 {
                x0 + span * ((k / 5) as f64 / 9.0)
            } else {
                x0 + span * (1.0 - (k - 50) as f64 / 10.0)
            };
            let y = height / 2.0 + 0.02 * height * ((line % 8) as f64 - 3.5);
            CanvasPos {
                x_px: x + ((i * 7919) % 13) as f64 * 0.2,
                y_px: y,
            }
        })
        .collect()
}

/// A conversation-like trajectory: larger saccades between random targets
/// over most of the canvas, each held for 4-20 frames.
pub fn conversation_trajectory(
    frames: usize,
    width: f64,
    height: f64,
    seed: u64,
) -> Vec<CanvasPos> {
    let mut r = crate::rng::SplitMix64::new(seed);
    let mut out = Vec::with_capacity(frames);
    let mut target = CanvasPos {
        x_px: width / 2.0,
        y_px: height / 2.0,
    };
    let mut cur = target;
    while out.len() < frames {
        let hold = 4 + r.below(17);
        target = CanvasPos {
            x_px: width * r.range(0.1, 0.9),
            y_px: height * r.range(0.15, 0.85),
        };
        for j in 0..hold {
            // Two-frame saccade, then fixation.
            let a = ((j + 1) as f64 / 2.0).min(1.0);
            cur = CanvasPos {
                x_px: cur.x_px + (target.x_px - cur.x_px) * a,
                y_px: cur.y_px + (target.y_px - cur.y_px) * a,
            };
            out.push(cur);
        }
    }
    out.truncate(frames);
    out
}

/// Keeps every frame in one buffer that was allocated and touched before
/// timing starts, so page faults do not count as rendering time.
struct Keep {
    frames: Vec<u8>,
    frame_bytes: usize,
}
impl FrameSink for Keep {
    fn frame(&mut self, i: usize, yuv: &[u8]) -> Result<(), RenderError> {
        let n = self.frame_bytes;
        self.frames[i * n..(i + 1) * n].copy_from_slice(yuv);
        Ok(())
    }
}

/// Runs the three measurements; the video goes to a temporary directory.
pub fn run_bench(params: &RenderParams, frames: usize) -> Result<BenchReport, RenderError> {
    params.validate()?;
    let canvas = params.mapping.canvas;
    let traj = reading_trajectory(frames, canvas.width_px as f64, canvas.height_px as f64);
    let t = Instant::now();
    let scene = Scene::new(&params.identity, params.width, params.height);
    let scene_setup_s = t.elapsed().as_secs_f64();
    let truth = solve_truth(&scene, &traj, None, params);
    let shape = BenchShape {
        frames,
        width: params.width,
        height: params.height,
        fps: params.fps,
    };
    time_bench(
        shape,
        &params.encoder,
        scene_setup_s,
        |keep| render_frames(&scene, &truth, keep),
        // End to end, through the public entry point.
        |dir| {
            render_session(
                &traj,
                None,
                params,
                &dir.join("session.mp4"),
                &dir.join("session_truth.csv"),
            )
            .map(|_| ())
        },
    )
}

/// What a bench renders: `frames` frames of `width` x `height` at `fps`.
#[derive(Clone, Copy, Debug)]
pub struct BenchShape {
    pub frames: usize,
    pub width: usize,
    pub height: usize,
    pub fps: f64,
}

/// The most frame bytes a bench keeps in memory (4 GiB): the encode-only
/// timing replays the drawn frames, so all of them are held at once.
pub const MAX_KEPT_BYTES: usize = 4 << 30;

/// A bench of `frames` frames of `width`x`height` keeps at most
/// [`MAX_KEPT_BYTES`] in memory; checked again by [`time_bench`], and by
/// the command before any setup, so that a refusal comes at once.
pub fn check_kept_frames(frames: usize, width: usize, height: usize) -> Result<(), RenderError> {
    let frame_bytes = width * height * 3 / 2;
    if frames.saturating_mul(frame_bytes) > MAX_KEPT_BYTES {
        return Err(RenderError::Params(format!(
            "--frames {frames} at {width}x{height} would keep {:.1} GB of frames in memory (the encode-only timing replays them); at most {} frames at this size",
            frames.saturating_mul(frame_bytes) as f64 / 1e9,
            MAX_KEPT_BYTES / frame_bytes.max(1)
        )));
    }
    Ok(())
}

/// The three measurements of a renderer's bench, in one run on the same
/// frames: `render` draws every frame into the sink it is given (kept in
/// memory; the copy is timed too, so render-only is slightly pessimistic),
/// the encoder alone is fed those frames with `encoder`, and `end_to_end`
/// renders the whole session into the folder it is given (a temporary
/// one). Wall time and CPU time (this process, and ffmpeg) of each.
pub fn time_bench<E: From<RenderError>>(
    shape: BenchShape,
    encoder: &EncoderSettings,
    scene_setup_s: f64,
    render: impl FnOnce(&mut (dyn FrameSink + Send)) -> Result<(), E>,
    end_to_end: impl FnOnce(&std::path::Path) -> Result<(), E>,
) -> Result<BenchReport, E> {
    let BenchShape {
        frames,
        width,
        height,
        fps,
    } = shape;
    check_kept_frames(frames, width, height)?;
    let frame_bytes = width * height * 3 / 2;
    // Listed, so that a stop (Ctrl-C) removes it too.
    let dir = eyereplay_core::inflight::ListedTempDir::new()
        .map_err(|e| RenderError::io(std::env::temp_dir(), e))?;
    let mut keep = Keep {
        frames: vec![1u8; frames * frame_bytes],
        frame_bytes,
    };
    let c0 = cpu_times();
    let t = Instant::now();
    render(&mut keep)?;
    let render_s = t.elapsed().as_secs_f64();
    let c1 = cpu_times();

    let t = Instant::now();
    let out = dir.path().join("encode_only.mp4");
    let mut enc = Encoder::start(&out, width, height, fps, encoder)?;
    for f in keep.frames.chunks(frame_bytes) {
        enc.write_frame(f)?;
    }
    enc.finish()?;
    let encode_s = t.elapsed().as_secs_f64();
    let c2 = cpu_times();
    drop(keep);

    let t = Instant::now();
    end_to_end(dir.path())?;
    let e2e_s = t.elapsed().as_secs_f64();
    let c3 = cpu_times();
    let n = frames as f64;
    let ms = |a: Option<(f64, f64)>, b: Option<(f64, f64)>, pick: fn((f64, f64)) -> f64| {
        Some((pick(b?) - pick(a?)) * 1000.0 / n)
    };
    let render_cpu_ms = ms(c0, c1, |c| c.0);
    let encode_cpu_ms = ms(c1, c2, |c| c.0 + c.1);
    let end_to_end_cpu_ms = ms(c2, c3, |c| c.0 + c.1);
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());

    Ok(BenchReport {
        frames,
        width,
        height,
        video_fps: fps,
        render_fps: n / render_s,
        encode_fps: n / encode_s,
        end_to_end_fps: n / e2e_s,
        realtime_factor: n / e2e_s / fps,
        ratio_to_encode: encode_s / e2e_s,
        scene_setup_s,
        render_cpu_ms,
        encode_cpu_ms,
        end_to_end_cpu_ms,
        cpu_bound_fps: end_to_end_cpu_ms.map(|m| cores as f64 * 1000.0 / m),
        cores,
        second_pass: None,
    })
}

/// CPU seconds used so far by this process (`self_s`) and by its waited-for
/// children such as ffmpeg (`children_s`), from /proc/self/stat. CPU time
/// is what the 2-core budget is made of, and unlike wall time it does not
/// change when other work shares the machine. `None` off Linux.
pub fn cpu_times() -> Option<(f64, f64)> {
    let s = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the parenthesised command name; utime is field 14.
    let rest = &s[s.rfind(')')? + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let tick = 100.0; // USER_HZ on Linux
    let n = |i: usize| -> Option<f64> { f.get(i)?.parse::<f64>().ok().map(|v| v / tick) };
    Some((n(11)? + n(12)?, n(13)? + n(14)?))
}
