//! Speed of the browser backend against the encoder alone, measured in one
//! run on the same frames.

use crate::capture::Capture;
use crate::session::{decode_image, render_session_browser};
use crate::settings::{BrowserSettings, TEST_PAGE_URL};
use crate::{test_page, BrowserError};
use eyereplay_render::{cpu_times, reading_trajectory, rgb_to_yuv420, Encoder, EncoderSettings};
use std::time::Instant;

/// What [`run_bench`] measured.
#[derive(Clone, Debug, serde::Serialize)]
pub struct BrowserBenchReport {
    pub frames: usize,
    pub width: usize,
    pub height: usize,
    pub fps: f64,
    pub browser_version: String,
    /// Browser start, page load, readiness and warm-up, s.
    pub startup_s: f64,
    /// Frames per second of the browser alone (move, advance, draw,
    /// screenshot), nothing decoded or encoded.
    pub capture_fps: f64,
    /// Frames per second decoding screenshots to yuv420p.
    pub decode_fps: f64,
    /// Frames per second of the x264 encoder alone, fed the decoded frames.
    pub encode_fps: f64,
    /// Frames per second of `render_session_browser`'s frame loop (capture,
    /// decode and encode overlapped), start-up excluded.
    pub end_to_end_fps: f64,
    /// End-to-end frames per second over the encoder's alone.
    pub ratio_to_encoder: f64,
    /// Test page only: frames whose pixel codes were checked, and those
    /// that showed a wrong frame number or cursor (late or repeated).
    pub checked_frames: usize,
    pub wrong_frames: usize,
    /// CPU time per frame, ms: the browser's processes during capture
    /// (start-up included), decoding, and ffmpeg encoding. Unlike frames/s
    /// it does not depend on what else runs on the machine.
    pub cpu_ms_per_frame: Option<f64>,
    /// The browser's part of it, ms.
    pub browser_cpu_ms_per_frame: Option<f64>,
    /// Frames per second the machine's cores could sustain at that CPU cost.
    pub cpu_bound_fps: Option<f64>,
}

impl std::fmt::Display for BrowserBenchReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "browser bench: {} frames {}x{} at {} fps ({})",
            self.frames, self.width, self.height, self.fps, self.browser_version
        )?;
        writeln!(f, "  start-up              {:8.2} s", self.startup_s)?;
        writeln!(
            f,
            "  browser capture only  {:8.1} frames/s",
            self.capture_fps
        )?;
        writeln!(
            f,
            "  decode to yuv420p     {:8.1} frames/s",
            self.decode_fps
        )?;
        writeln!(
            f,
            "  encoder alone         {:8.1} frames/s",
            self.encode_fps
        )?;
        writeln!(
            f,
            "  browser + encode      {:8.1} frames/s  ({:.2} x the encoder alone, {:.2} x real time)",
            self.end_to_end_fps,
            self.ratio_to_encoder,
            self.end_to_end_fps / self.fps
        )?;
        if let (Some(ms), Some(lim)) = (self.cpu_ms_per_frame, self.cpu_bound_fps) {
            writeln!(
                f,
                "  CPU per frame         {ms:8.1} ms ({:.1} ms browser) -> CPU-bound limit {lim:.1} frames/s on {} cores",
                self.browser_cpu_ms_per_frame.unwrap_or(f64::NAN),
                cores()
            )?;
        }
        if self.checked_frames > 0 {
            writeln!(
                f,
                "  frame check           {} frames, {} late or repeated",
                self.checked_frames, self.wrong_frames
            )?;
        }
        Ok(())
    }
}

/// Renders `frames` frames of a reading-like trajectory three ways: browser
/// capture only, encoder alone on the decoded frames, and the full session
/// render (capture + decode + encode). Temporary files only.
pub fn run_bench(
    settings: &BrowserSettings,
    encoder: &EncoderSettings,
    frames: usize,
    fps: f64,
) -> Result<BrowserBenchReport, BrowserError> {
    let [cw, ch] = settings.mapping.canvas_px;
    let traj = reading_trajectory(frames.max(1), cw as f64, ch as f64);
    let page: Vec<[f64; 2]> = traj.iter().map(|p| settings.mapping.to_page(*p)).collect();
    let (w, h) = settings.video_size();
    // Listed, so that a stop (Ctrl-C) removes it too.
    let dir = eyereplay_core::inflight::ListedTempDir::new()
        .map_err(|e| BrowserError::io(std::env::temp_dir(), e))?;

    // 1. Browser alone.
    let t = Instant::now();
    let mut cap = Capture::open(settings, fps)?;
    let startup_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let mut shots = Vec::with_capacity(page.len());
    for p in &page {
        shots.push(cap.frame(*p)?.image);
    }
    let capture_s = t.elapsed().as_secs_f64();
    let browser_version = cap.browser_version.clone();
    let browser_cpu_s = group_cpu_s(cap.browser_pid());
    cap.close();

    // 2. Decode (and check the test page's codes, untimed).
    let check = settings.url.starts_with(TEST_PAGE_URL) && settings.crop.is_none();
    let (mut checked, mut wrong) = (0, 0);
    let mut yuvs = Vec::with_capacity(shots.len());
    let mut decode_s = 0.0;
    let mut first_frame = None;
    for (i, s) in shots.iter().enumerate() {
        let t = Instant::now();
        let (rgb, iw, ih) = decode_image(s, settings.format).map_err(|e| BrowserError::Frame {
            frame: i,
            message: e.to_string(),
        })?;
        let mut yuv = vec![0u8; w * h * 3 / 2];
        rgb_to_yuv420(&rgb, iw, [0, 0, w, h], &mut yuv, w, h);
        decode_s += t.elapsed().as_secs_f64();
        if check {
            checked += 1;
            let ok = test_page::decode_codes(&rgb, iw, ih).is_ok_and(|c| {
                let f0 = *first_frame.get_or_insert(c.frame.wrapping_sub(i as u32));
                let expect = [
                    (page[i][0] * 16.0).round() as u32,
                    (page[i][1] * 16.0).round() as u32,
                ];
                c.frame == f0 + i as u32 && c.mouse_16 == Some(expect)
            });
            wrong += (!ok) as usize;
        }
        yuvs.push(yuv);
    }
    drop(shots);

    // 3. Encoder alone.
    let cpu_enc0 = cpu_times();
    let t = Instant::now();
    let mut enc = Encoder::start(&dir.path().join("encode_only.mp4"), w, h, fps, encoder)?;
    for y in &yuvs {
        enc.write_frame(y)?;
    }
    enc.finish()?;
    let encode_s = t.elapsed().as_secs_f64();
    let encoder_cpu_s = cpu_enc0.zip(cpu_times()).map(|((_, c0), (_, c1))| c1 - c0);
    drop(yuvs);

    // 4. The real thing.
    let stats = render_session_browser(
        settings,
        encoder,
        &traj,
        fps,
        &dir.path().join("bench.mp4"),
        &dir.path().join("bench_truth.csv"),
    )?;
    let n = traj.len() as f64;
    // Decoding runs on one thread, so its wall time is its CPU time.
    let browser_cpu_ms_per_frame = browser_cpu_s.map(|s| s * 1000.0 / n);
    let cpu_ms_per_frame = browser_cpu_s
        .zip(encoder_cpu_s)
        .map(|(b, e)| (b + e + decode_s) * 1000.0 / n);
    let encode_fps = n / encode_s.max(1e-9);
    let end_to_end_fps = stats.capture_fps();
    Ok(BrowserBenchReport {
        frames: traj.len(),
        width: w,
        height: h,
        fps,
        browser_version,
        startup_s,
        capture_fps: n / capture_s.max(1e-9),
        decode_fps: n / decode_s.max(1e-9),
        encode_fps,
        end_to_end_fps,
        ratio_to_encoder: end_to_end_fps / encode_fps,
        checked_frames: checked,
        wrong_frames: wrong,
        cpu_ms_per_frame,
        browser_cpu_ms_per_frame,
        cpu_bound_fps: cpu_ms_per_frame.map(|ms| cores() as f64 * 1000.0 / ms.max(1e-9)),
    })
}

/// CPU seconds used so far by the live processes of process group `pgid`
/// (the browser and its helpers), from /proc. `None` off Linux.
fn group_cpu_s(pgid: i32) -> Option<f64> {
    let mut total = 0.0;
    for e in std::fs::read_dir("/proc").ok()?.flatten() {
        let Ok(stat) = std::fs::read_to_string(e.path().join("stat")) else {
            continue;
        };
        let Some(rest) = stat.rfind(')').map(|i| &stat[i + 2..]) else {
            continue;
        };
        let f: Vec<&str> = rest.split_whitespace().collect();
        // After the command name: state, ppid, pgrp, ..., utime (11), stime (12).
        if f.get(2).and_then(|v| v.parse::<i32>().ok()) == Some(pgid) {
            let n = |i: usize| f.get(i).and_then(|v| v.parse::<f64>().ok()).unwrap_or(0.0);
            total += (n(11) + n(12)) / 100.0;
        }
    }
    Some(total)
}

fn cores() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}
