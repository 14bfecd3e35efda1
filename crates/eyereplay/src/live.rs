//! Watching a call as it happens (`eyereplay detect --live SOURCE`): frames
//! from a camera, a network stream or standard input go through the same
//! extractor and detector as a recorded file, and each window's reading
//! probability is reported as soon as the window closes.
//!
//! The stream is decoded by the same decoder as a file, read by one
//! face tracker frame after frame, and turned into the same 25 fps track
//! ([`rows_track`] is what the extractor's CSV gives, value for value), so
//! a recording played through standard input ends with the segments the
//! offline run finds. Lost frames leave gaps in the track (no frame is
//! invented); a lost face leaves frames without gaze; a window with too
//! little gaze is reported as such and the watch goes on.

use crate::detector::{
    detect_track, recording_end_s, resample_grid, resample_samples, Detection, TrackInfo,
};
use crate::inputs::check_models;
use crate::{Error, Result};
use eyereplay_core::{NormPos, Sample};
use eyereplay_detect::{DetectorModel, Track, FPS};
use eyereplay_extract::{
    blink_threshold, flag_blinks_below, Decoder, ExtractOptions, FrameStream, Row,
};
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Instant;

/// Where live frames come from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum LiveSource {
    /// `-`: a video stream on standard input (NUT, Matroska, MPEG-TS:
    /// `ffmpeg -i call.mp4 -f nut -c:v rawvideo -pix_fmt rgb24 -`).
    Stdin,
    /// A camera device (`/dev/video0`), opened through the ffmpeg program.
    Camera(PathBuf),
    /// Anything FFmpeg opens by name: `rtsp://`, `http://`, a file.
    Url(String),
}

impl LiveSource {
    pub fn parse(s: &str) -> LiveSource {
        if s == "-" {
            LiveSource::Stdin
        } else if s.starts_with("/dev/video") {
            LiveSource::Camera(PathBuf::from(s))
        } else {
            LiveSource::Url(s.to_string())
        }
    }

    pub fn label(&self) -> String {
        match self {
            LiveSource::Stdin => "stdin".into(),
            LiveSource::Camera(p) => p.display().to_string(),
            LiveSource::Url(u) => u.clone(),
        }
    }
}

/// One window, reported when it closes.
#[derive(Clone, Debug, PartialEq)]
pub struct LiveWindow {
    /// Seconds from the stream's first frame.
    pub start_s: f64,
    pub end_s: f64,
    /// `None` when the window had too little gaze to score.
    pub reading_probability: Option<f64>,
    pub reading: bool,
    /// Seconds of the window with gaze.
    pub gaze_s: f64,
    /// How long after the window's end, on a clock that started with the
    /// first frame, the probability was ready: the delay a viewer of a
    /// real-time stream sees. Near 0 (or below) when the input comes
    /// faster than real time.
    pub lag_s: f64,
}

/// What ends a watch before its stream does.
#[derive(Clone, Debug, Default)]
pub struct Stop {
    /// Set from elsewhere (the command's Ctrl-C handler, another thread)
    /// to end the watch: the windows so far, and the whole stream's
    /// result, still come. A read that waits for data is cut short (for a
    /// pipe, by the signal that sets it).
    pub requested: Arc<AtomicBool>,
    /// A stream that gives no frame for this long is taken as ended, with
    /// a warning. Network streams are watched for it; a pipe's read waits
    /// until data or a signal comes. `None`: wait as long as it takes.
    pub stall_s: Option<f64>,
}

/// Why a watch ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LiveEnd {
    /// The stream's own end.
    StreamEnded,
    /// [`Stop::requested`] was set.
    Stopped,
    /// No frame for [`Stop::stall_s`].
    Stalled,
}

/// What a watch ends with.
pub struct LiveOutcome {
    pub end: LiveEnd,
    /// The whole stream's detection, as `detect` gives it for a file (the
    /// segments from the complete track); or why there is none (too little
    /// gaze: how much there was and how much a score needs), as `detect`
    /// says it of a file.
    pub detection: std::result::Result<Detection, String>,
    pub track: Track,
    pub frames: usize,
    pub face_frames: usize,
}

/// The 25 fps gaze track of extractor rows, exactly as the extractor's CSV
/// of those rows reads back ([`crate::detector::extract_csv_track`]):
/// times to the microsecond and positions to 5 decimals as the CSV writes
/// them, blinks and frames without a face as no gaze.
pub fn rows_track(rows: &[Row]) -> Track {
    let samples = rows_samples(rows);
    let refs: Vec<&Sample<NormPos>> = samples.iter().collect();
    resample_samples(&refs)
}

/// The samples the extractor's CSV of `rows` reads back as: times to the
/// microsecond and positions to 5 decimals as the CSV writes them.
fn rows_samples(rows: &[Row]) -> Vec<Sample<NormPos>> {
    // The CSV's text is `{:.N}`; parsing it back is this rounding.
    let round = |v: f64, digits: usize| format!("{v:.digits$}").parse().unwrap_or(v);
    rows.iter()
        .map(|r| {
            let (nx, ny) = r
                .mean_n()
                .filter(|_| r.face())
                .map_or((f64::NAN, f64::NAN), |(x, y)| (round(x, 5), round(y, 5)));
            Sample {
                t_s: round(r.time_s, 6),
                pos: NormPos { nx, ny },
                valid: r.valid() && nx.is_finite() && ny.is_finite(),
                aperture: r.aperture().filter(|a| a.is_finite()).map(|a| round(a, 5)),
                blink: r.blink,
            }
        })
        .collect()
}

/// When the stream of `rows` ends so far, as [`rows_track`] reckons it
/// (the last row lasts one frame interval).
fn rows_end_s(rows: &[Row]) -> f64 {
    let tail = rows_samples(&rows[rows.len().saturating_sub(2)..]);
    let refs: Vec<&Sample<NormPos>> = tail.iter().collect();
    recording_end_s(&refs)
}

/// Frames `next..next + frames` of the 25 fps track of `rows` (whose first
/// row is at `t0`), blinks flagged against `threshold`, made from the rows
/// around those frames alone: the same values as the whole track's, at a
/// cost that does not grow with the stream.
fn window_track(rows: &[Row], threshold: f64, t0: f64, next: usize, frames: usize) -> Track {
    let end_s = rows_end_s(rows);
    let start_t = t0 + next as f64 / FPS;
    let end_t = t0 + (next + frames) as f64 / FPS;
    // Two rows either side: one for the interpolation at the window's
    // edge, one more for that row's blink neighbour.
    let from = rows
        .partition_point(|r| r.time_s < start_t)
        .saturating_sub(2);
    let to = (rows.partition_point(|r| r.time_s < end_t) + 2).min(rows.len());
    let mut part = rows[from..to.max(from)].to_vec();
    flag_blinks_below(&mut part, threshold);
    let samples = rows_samples(&part);
    let refs: Vec<&Sample<NormPos>> = samples.iter().collect();
    resample_grid(&refs, t0, next..next + frames, end_s)
}

/// Opens `source`: standard input and URLs by the decoder itself; a camera
/// through an ffmpeg child process whose output the decoder reads. Every
/// wait for data asks `interrupt` whether to give up.
fn open(
    source: &LiveSource,
    ffmpeg: &Path,
    interrupt: impl FnMut() -> bool + Send + 'static,
) -> Result<(Decoder, Option<std::process::Child>)> {
    match source {
        LiveSource::Stdin => Decoder::open_url("pipe:0", interrupt)
            .map(|d| (d, None))
            .map_err(|e| match e {
                // FFmpeg names standard input "pipe:0"; say what it was.
                eyereplay_extract::ExtractError::Open { message, .. } => Error::input(
                    "stdin",
                    format!(
                        "no video stream could be read from it ({message}); pipe one in, for \
                         example: ffmpeg -re -i call.mp4 -f nut -c:v rawvideo -pix_fmt yuv420p -"
                    ),
                ),
                e => e.into(),
            }),
        LiveSource::Url(u) => Ok((Decoder::open_url(u, interrupt)?, None)),
        LiveSource::Camera(dev) => {
            use std::os::fd::AsRawFd;
            // Said here in one line, rather than by ffmpeg's own lines.
            if !Path::new(dev).exists() {
                return Err(Error::input(dev, "no such camera device"));
            }
            let child = std::process::Command::new(ffmpeg)
                .args(["-hide_banner", "-loglevel", "error", "-f", "v4l2", "-i"])
                .arg(dev)
                .args([
                    "-f", "nut", "-c:v", "rawvideo", "-pix_fmt", "yuv420p", "pipe:1",
                ])
                .stdin(std::process::Stdio::null())
                .stdout(std::process::Stdio::piped())
                .spawn()
                .map_err(|e| {
                    Error::input(ffmpeg, format!("cannot run ffmpeg to open the camera: {e}"))
                })?;
            let fd = child.stdout.as_ref().expect("piped above").as_raw_fd();
            let dec = Decoder::open_url(&format!("pipe:{fd}"), interrupt).map_err(|e| {
                Error::input(dev, format!("camera gave no video through ffmpeg: {e}"))
            })?;
            Ok((dec, Some(child)))
        }
    }
}

/// Which windows have been reported, and the clocks to say when.
struct WindowClock {
    /// First frame (at 25 fps) of the next window to report.
    next: usize,
    window_frames: usize,
    stride_frames: usize,
    /// The first frame's stream time, and when it arrived.
    t0: Option<(f64, Instant)>,
    blink_ratio: f64,
}

impl WindowClock {
    /// Reports every window whose end the stream has passed at stream time
    /// `now_s` (every remaining one when `None`: the stream ended).
    fn close(
        &mut self,
        rows: &[Row],
        now_s: Option<f64>,
        model: &DetectorModel,
        on_window: &mut dyn FnMut(&LiveWindow),
    ) {
        let Some((t0, wall0)) = self.t0 else {
            return;
        };
        let reached = now_s.map(|t| ((t - t0) * FPS + 1e-6).floor() as usize);
        let due = |next: usize| reached.is_none_or(|g| g >= next + self.window_frames);
        let last_t = rows.last().map_or(t0, |r| r.time_s);
        // At the stream's end its last row lasts one frame interval, as
        // it does in the file's track ([`rows_track`]).
        let end_s = rows_end_s(rows);
        let covered = |next: usize| {
            let last_frame_t = t0 + (next + self.window_frames - 1) as f64 / FPS;
            last_frame_t <= last_t + 1e-9 || (now_s.is_none() && last_frame_t < end_s - 1e-9)
        };
        if !due(self.next) || !covered(self.next) {
            return;
        }
        // Blinks against the median aperture so far (the whole stream's
        // at the end, as for a file); only the window's own rows are read
        // again, so a long call costs no more per window than a short one.
        let threshold = blink_threshold(rows, self.blink_ratio).unwrap_or(f64::NEG_INFINITY);
        while due(self.next) && covered(self.next) {
            let window = window_track(rows, threshold, t0, self.next, self.window_frames);
            let gaze = window.xy.iter().filter(|p| p[0].is_finite()).count();
            let p = eyereplay_detect::window::prepare_window(&window.xy, self.next)
                .map(|win| model.probability(&win));
            let end_s = (self.next + self.window_frames) as f64 / FPS;
            on_window(&LiveWindow {
                start_s: self.next as f64 / FPS,
                end_s,
                reading_probability: p,
                reading: p.is_some_and(|p| p >= model.threshold),
                gaze_s: gaze as f64 / FPS,
                lag_s: wall0.elapsed().as_secs_f64() - end_s,
            });
            self.next += self.stride_frames;
        }
    }
}

/// Frames after which a watch says whether they come too far apart to be
/// joined ([`crate::detector::sparse_frames_warning`]): 8 s at 5 a second.
const SPARSE_CHECK_FRAMES: usize = 40;

/// What a watch tells as it goes.
pub trait LiveObserver {
    /// A window closed.
    fn window(&mut self, w: &LiveWindow);
    /// Something the viewer should know that does not stop the watch (the
    /// stream's clock went back, it stalled).
    fn warning(&mut self, message: &str);
    /// The source opened: its picture's size. A viewer's "watching ..."
    /// belongs here, not before the open, which may fail.
    fn opened(&mut self, _width: usize, _height: usize) {}
}

/// With no face in this many seconds of a stream, the watch says so once:
/// a camera pointed elsewhere should not take the whole call to show.
const NO_FACE_WARN_S: f64 = 10.0;

/// Watches `source` until it ends or `stop` ends it, telling `observer`
/// every window of the model's length, one second apart, as it closes;
/// then scores the whole stream as [`detect_track`] scores a file
/// (`model_path` names the model in that result).
pub fn watch(
    source: &LiveSource,
    model: &DetectorModel,
    model_path: &Path,
    ffmpeg: &Path,
    stop: &Stop,
    observer: &mut dyn LiveObserver,
) -> Result<LiveOutcome> {
    check_models()?;
    // When the last frame came, in ms after the source was opened; the
    // interrupt callback compares it with the stall limit.
    let opened = Instant::now();
    let last_frame_ms = Arc::new(AtomicU64::new(0));
    let stalled = Arc::new(AtomicBool::new(false));
    let interrupt = {
        let (requested, last, stalled) = (
            stop.requested.clone(),
            last_frame_ms.clone(),
            stalled.clone(),
        );
        let stall_ms = stop.stall_s.map(|s| (s * 1000.0) as u64);
        move || {
            if requested.load(Ordering::Relaxed) {
                return true;
            }
            let now = opened.elapsed().as_millis() as u64;
            let quiet = now.saturating_sub(last.load(Ordering::Relaxed));
            if stall_ms.is_some_and(|limit| quiet > limit) {
                stalled.store(true, Ordering::Relaxed);
                return true;
            }
            false
        }
    };
    let opening = open(source, ffmpeg, interrupt);
    if stop.requested.load(Ordering::Relaxed) || stalled.load(Ordering::Relaxed) {
        if let Ok((_, Some(mut c))) = opening {
            let _ = c.kill();
            let _ = c.wait();
        }
        let why = if stalled.load(Ordering::Relaxed) {
            format!(
                "no video came for {:.0} s; gave up (--stall-timeout-s)",
                stop.stall_s.unwrap_or(0.0)
            )
        } else {
            "stopped before the stream's first frame".into()
        };
        return Err(Error::input(source.label(), why));
    }
    let (mut decoder, child) = opening?;
    let opts = ExtractOptions::default();
    let (w, h) = (decoder.info.width, decoder.info.height);
    observer.opened(w, h);
    let mut face_checked = false;
    let mut stream = FrameStream::new(&opts, w, h)?;
    let mut clock = WindowClock {
        next: 0,
        window_frames: (model.window_s * FPS).round() as usize,
        stride_frames: (eyereplay_detect::localize::STRIDE_S * FPS).round() as usize,
        t0: None,
        blink_ratio: opts.blink_ratio,
    };
    let mut failure: Option<Error> = None;
    let mut rebase = Rebase::default();
    let decoded = decoder.frames(|t, img| {
        if stop.requested.load(Ordering::Relaxed) {
            return Ok(ControlFlow::Break(()));
        }
        last_frame_ms.store(opened.elapsed().as_millis() as u64, Ordering::Relaxed);
        let t = match rebase.time(t) {
            Timed::At(t) => t,
            Timed::Restarted(t, message) => {
                observer.warning(&message);
                t
            }
            Timed::Behind => return Ok(ControlFlow::Continue(())),
        };
        match stream.push_image(img, t) {
            Ok(()) => {}
            Err(e) => {
                failure = Some(e.into());
                return Ok(ControlFlow::Break(()));
            }
        }
        // Once there are enough frames to tell: too sparse to join?
        if stream.frames() == SPARSE_CHECK_FRAMES {
            let times: Vec<f64> = stream.rows().iter().map(|r| r.time_s).collect();
            if let Some(w) = crate::detector::sparse_frames_warning(&times) {
                observer.warning(&w);
            }
        }
        let (t0, _) = *clock.t0.get_or_insert_with(|| (t, Instant::now()));
        if !face_checked && t - t0 >= NO_FACE_WARN_S {
            face_checked = true;
            if !stream.rows().iter().any(|r| r.face()) {
                observer.warning(&format!(
                    "no face in the first {NO_FACE_WARN_S:.0} s of the stream: is the camera \
                     pointed at a face? (the watch goes on)"
                ));
            }
        }
        clock.close(stream.rows(), Some(t), model, &mut |w| observer.window(w));
        Ok(ControlFlow::Continue(()))
    });
    if let Some(mut c) = child {
        let _ = c.kill();
        let _ = c.wait();
    }
    decoded?;
    if let Some(e) = failure {
        return Err(e);
    }
    let end = if stop.requested.load(Ordering::Relaxed) {
        LiveEnd::Stopped
    } else if stalled.load(Ordering::Relaxed) {
        observer.warning(&format!(
            "no frame for {:.0} s: the stream stalled, so the watch ends here (--stall-timeout-s)",
            stop.stall_s.unwrap_or(0.0)
        ));
        LiveEnd::Stalled
    } else {
        LiveEnd::StreamEnded
    };
    let frames = stream.frames();
    if frames == 0 {
        return Err(Error::input(
            source.label(),
            match end {
                LiveEnd::StreamEnded => "the stream ended before its first frame",
                _ => "stopped before the stream's first frame",
            },
        ));
    }
    clock.close(stream.rows(), None, model, &mut |w| observer.window(w));
    let done = stream.finish()?;
    let track = rows_track(&done.rows);
    let gaze = track.xy.iter().filter(|p| p[0].is_finite()).count();
    let info = TrackInfo {
        path: source.label(),
        kind: "live".into(),
        frames: track.len(),
        gaze_fraction: gaze as f64 / track.len().max(1) as f64,
    };
    // Too little gaze for any score is a result here, not an error: the
    // windows already said so as they closed.
    let detection = detect_track(&track, info, model, model_path).map_err(|e| e.to_string());
    Ok(LiveOutcome {
        end,
        detection,
        track,
        frames,
        face_frames: done.face_frames,
    })
}

/// A stream's clock made to run forward. A camera, an encoder or a
/// segmenter that restarts sends times that start again from zero (or
/// jump back by more than [`Rebase::RESTART_S`]); the frames after it
/// continue the clock from the last frame, one frame interval on, where
/// the extractor would drop every one of them until the new times passed
/// the old. A frame a moment behind the last (a repeated time) is dropped,
/// as a file's would be.
#[derive(Default)]
struct Rebase {
    /// Added to every incoming time since the last restart.
    offset_s: f64,
    /// The first frame's time: the tables count from it, and so does
    /// the warning (an MPEG-TS stream starts at 1.4 s, say).
    first: Option<f64>,
    /// The last time given out, and the last interval between frames.
    last: Option<f64>,
    interval_s: Option<f64>,
}

/// What to do with a frame, by its time.
#[derive(Debug, PartialEq)]
enum Timed {
    /// Keep it at this time.
    At(f64),
    /// Keep it at this time, which continues the clock after a restart;
    /// the warning says so.
    Restarted(f64, String),
    /// A moment behind the last frame: dropped.
    Behind,
}

impl Rebase {
    /// A jump back of more than this is a restart, not jitter.
    const RESTART_S: f64 = 1.0;

    fn time(&mut self, t_s: f64) -> Timed {
        let t = t_s + self.offset_s;
        let Some(last) = self.last else {
            if !t.is_finite() {
                return Timed::Behind;
            }
            self.last = Some(t);
            self.first = Some(t);
            return Timed::At(t);
        };
        let continued = last + self.interval_s.unwrap_or(1.0 / FPS);
        if !t.is_finite() {
            // No usable time: the next frame's place on the clock.
            self.last = Some(continued);
            return Timed::At(continued);
        }
        if t > last {
            self.interval_s = Some((t - last).min(1.0));
            self.last = Some(t);
            return Timed::At(t);
        }
        if last - t <= Self::RESTART_S {
            return Timed::Behind;
        }
        self.offset_s = continued - t_s;
        self.last = Some(continued);
        let first = self.first.unwrap_or(0.0);
        Timed::Restarted(
            continued,
            format!(
                "the stream's clock went back by {:.2} s at {:.2} s into the stream (a restarted \
                 camera or encoder?); its frames continue from there",
                last - t,
                continued - first
            ),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_track_of_rows_is_the_track_of_their_csv() {
        // Rows at a jittery ~30 fps with a lost face and a blink: the track
        // made from them in memory equals the one read from their CSV.
        let mut rows: Vec<Row> = (0..120)
            .map(|k| {
                let mut r = if (40..46).contains(&k) {
                    Row::synthetic(None)
                } else {
                    let a = if (80..83).contains(&k) { 0.05 } else { 0.3 };
                    Row::synthetic(Some((
                        a,
                        (
                            0.4 + 0.123_456_789 * (k as f64 * 0.3).sin(),
                            0.5 + 0.01 * k as f64,
                        ),
                    )))
                };
                r.frame = k;
                r.time_s = 1.5 + k as f64 / 30.0 + 0.003 * ((k * 7) % 3) as f64;
                r
            })
            .collect();
        eyereplay_extract::flag_blinks(&mut rows, 0.6);
        assert!(rows.iter().any(|r| r.blink));
        let dir = tempfile::tempdir().unwrap();
        let csv = dir.path().join("x.csv");
        eyereplay_extract::save_csv(&csv, &rows).unwrap();
        let from_csv = crate::detector::extract_csv_track(&csv).unwrap();
        let here = rows_track(&rows);
        assert_eq!(here.len(), from_csv.len());
        assert!(here.xy.iter().any(|p| p[0].is_nan()));
        for (a, b) in here.xy.iter().zip(&from_csv.xy) {
            for k in 0..2 {
                assert!(
                    a[k].to_bits() == b[k].to_bits() || (a[k].is_nan() && b[k].is_nan()),
                    "{a:?} vs {b:?}"
                );
            }
        }
        // A window made from the rows around it alone, as the live clock
        // makes it, is the same frames of the whole track; also where
        // frames were dropped (rows 58-65 gone: the first window's last
        // frames then need a row after its end).
        let dropped: Vec<Row> = rows
            .iter()
            .filter(|r| !(58..66).contains(&r.frame))
            .cloned()
            .collect();
        for rows in [&rows, &dropped] {
            let whole = rows_track(rows);
            let t0 = rows[0].time_s;
            let threshold = blink_threshold(rows, 0.6).unwrap();
            for next in [0usize, 20, 47, 50] {
                let w = window_track(rows, threshold, t0, next, 50);
                for (a, b) in w.xy.iter().zip(&whole.xy[next..next + 50]) {
                    assert!(
                        a[0].to_bits() == b[0].to_bits() || (a[0].is_nan() && b[0].is_nan()),
                        "frame after {next}: {a:?} vs {b:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn a_restarted_clock_continues_and_a_repeated_time_is_dropped() {
        let mut r = Rebase::default();
        assert_eq!(r.time(5.0), Timed::At(5.0));
        assert_eq!(r.time(5.04), Timed::At(5.04));
        // A repeated time and a small step back: dropped, as a file's.
        assert_eq!(r.time(5.04), Timed::Behind);
        assert_eq!(r.time(4.5), Timed::Behind);
        assert_eq!(r.time(5.08), Timed::At(5.08));
        // The clock starts again at 0: the frame comes one interval
        // (0.04 s) after the last, and so do the ones after it.
        let Timed::Restarted(t, message) = r.time(0.0) else {
            panic!("a restart")
        };
        assert!((t - 5.12).abs() < 1e-9, "{t}");
        // In the tables' time, which starts at the first frame (5.0 s).
        assert!(
            message.contains("went back by 5.08 s at 0.12 s into the stream"),
            "{message}"
        );
        let Timed::At(t) = r.time(0.04) else {
            panic!("continued")
        };
        assert!((t - 5.16).abs() < 1e-9, "{t}");
        // A time that is not a number takes the next frame's place.
        let Timed::At(t) = r.time(f64::NAN) else {
            panic!("placed")
        };
        assert!((t - 5.20).abs() < 1e-9, "{t}");
        let Timed::At(t) = r.time(0.12) else {
            panic!("continued")
        };
        assert!((t - 5.24).abs() < 1e-9, "{t}");
    }

    #[test]
    fn sources_are_told_apart_by_name() {
        assert_eq!(LiveSource::parse("-"), LiveSource::Stdin);
        assert_eq!(
            LiveSource::parse("/dev/video0"),
            LiveSource::Camera("/dev/video0".into())
        );
        assert_eq!(
            LiveSource::parse("rtsp://cam.local/stream"),
            LiveSource::Url("rtsp://cam.local/stream".into())
        );
    }
}
