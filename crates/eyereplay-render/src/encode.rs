//! H.264 encoding through an `ffmpeg` child process fed raw yuv420p on its
//! standard input (RESEARCH.md section 2: x264 veryfast is the sweet spot,
//! and piping yuv420p rather than RGB saves about 1 ms per frame).
//!
//! The child writes to a hidden temporary file beside the target, which is
//! renamed over the target only after ffmpeg exits successfully; on any
//! error the temporary file is removed, so no half-written video is ever
//! visible under the target name.

mod colour;

pub use colour::rgb_to_yuv420;
pub(crate) use colour::{chroma, yuv_of};

use crate::RenderError;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Stdio};

/// How frames are encoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Codec {
    /// libx264, `preset`, constant quality `crf`.
    H264,
    /// libx264 with `-qp 0`: lossless with respect to the piped yuv420p.
    Lossless,
}

#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct EncoderSettings {
    pub codec: Codec,
    pub preset: String,
    pub crf: u32,
    /// Extra x264 options (`-x264-params`).
    pub x264_params: Option<String>,
    /// x264 threads; `None` lets x264 choose.
    pub threads: Option<u32>,
    /// Average bitrate (kbit/s) instead of constant quality: a video call's
    /// rate control (`-b:v`, `-maxrate` the same, a 2 s buffer), for the
    /// full-face mode's webcam look. `None`: `crf`.
    #[serde(default)]
    pub bitrate_kbps: Option<u32>,
    /// x264 tune (`-tune`), e.g. `zerolatency` for a video call's
    /// real-time encoder (no B-frames, no lookahead).
    #[serde(default)]
    pub tune: Option<String>,
    /// The ffmpeg program (a name on PATH or a path).
    pub ffmpeg: PathBuf,
}

/// x264 options on top of the veryfast preset (see [`EncoderSettings`]).
pub const DEFAULT_X264_PARAMS: &str = "rc-lookahead=5:bframes=2:subme=1:trellis=0:me=dia";

impl Default for EncoderSettings {
    fn default() -> Self {
        EncoderSettings {
            codec: Codec::H264,
            preset: "veryfast".into(),
            crf: 18,
            // On top of the veryfast preset: a 5-frame lookahead and 2
            // B-frames instead of 10 and 3, and subpel refinement 1 instead
            // of 2. Measured here on rendered sessions: about 30 % less
            // encoder CPU, files within 3 % of plain veryfast at the same CRF.
            // Diamond motion search and no trellis quantization: another
            // 15 % less encoder CPU (3.3 vs 3.9 ms per 1280x720 frame) with
            // the same file size and PSNR (50.32 dB against a lossless
            // render of the same 750-frame reading session, both ways).
            x264_params: Some(DEFAULT_X264_PARAMS.into()),
            threads: None,
            bitrate_kbps: None,
            tune: None,
            ffmpeg: PathBuf::from("ffmpeg"),
        }
    }
}

/// x264's presets, fastest first (`x264 --help`).
pub const X264_PRESETS: [&str; 10] = [
    "ultrafast",
    "superfast",
    "veryfast",
    "faster",
    "fast",
    "medium",
    "slow",
    "slower",
    "veryslow",
    "placebo",
];

/// x264's tunings (`x264 --help`).
pub const X264_TUNES: [&str; 8] = [
    "film",
    "animation",
    "grain",
    "stillimage",
    "psnr",
    "ssim",
    "fastdecode",
    "zerolatency",
];

/// x264's largest constant rate factor for 8-bit video.
pub const MAX_CRF: u32 = 51;

/// Refuses a preset x264 does not have, naming it and the ones it has
/// (ffmpeg's own message names neither); for every setting that holds
/// one, the close-up's `preset` and the face mode's `x264_preset`.
pub fn check_x264_preset(preset: &str) -> Result<(), String> {
    if X264_PRESETS.contains(&preset) {
        Ok(())
    } else {
        Err(format!(
            "x264 preset '{preset}' is not one of {}",
            X264_PRESETS.join(", ")
        ))
    }
}

impl EncoderSettings {
    /// Rejects a preset, tuning or CRF that x264 would refuse (or, for the
    /// CRF, clamp without a word), before any frame is drawn; ffmpeg's own
    /// message for them names neither the option nor the value.
    pub fn validate(&self) -> Result<(), RenderError> {
        check_x264_preset(&self.preset).map_err(RenderError::Params)?;
        if let Some(t) = &self.tune {
            if !X264_TUNES.contains(&t.as_str()) {
                return Err(RenderError::Params(format!(
                    "x264 tune '{t}' is not one of {}",
                    X264_TUNES.join(", ")
                )));
            }
        }
        if self.crf > MAX_CRF {
            return Err(RenderError::Params(format!(
                "crf must be between 0 and {MAX_CRF} (x264, 8-bit), got {}",
                self.crf
            )));
        }
        if self.bitrate_kbps == Some(0) {
            return Err(RenderError::Params(
                "bitrate must be at least 1 kbit/s".into(),
            ));
        }
        Ok(())
    }
}

impl EncoderSettings {
    /// ffmpeg's arguments for the encoder: codec, preset, rate control,
    /// tune, `x264_params`, threads.
    fn x264_args(&self) -> Vec<String> {
        let mut a: Vec<String> = ["-c:v", "libx264", "-preset", &self.preset]
            .map(String::from)
            .to_vec();
        match (self.codec, self.bitrate_kbps) {
            (Codec::H264, Some(k)) => a.extend([
                "-b:v".into(),
                format!("{k}k"),
                "-maxrate".into(),
                format!("{k}k"),
                "-bufsize".into(),
                format!("{}k", 2 * k),
            ]),
            (Codec::H264, None) => a.extend(["-crf".into(), self.crf.to_string()]),
            (Codec::Lossless, _) => a.extend(["-qp".into(), "0".into()]),
        }
        if let Some(t) = self.tune.as_deref().filter(|t| !t.is_empty()) {
            a.extend(["-tune".into(), t.into()]);
        }
        if let Some(p) = self.x264_params.as_deref().filter(|p| !p.is_empty()) {
            a.extend(["-x264-params".into(), p.into()]);
        }
        if let Some(t) = self.threads {
            a.extend(["-threads".into(), t.to_string()]);
        }
        a
    }

    /// Encodes one black 64x64 frame with these settings and nothing
    /// written, before a job's sessions start: x264 only warns of a key it
    /// does not know in `x264_params` and then encodes without it (a typo
    /// would be a setting silently not applied), and it refuses some values
    /// only when it opens, after a session's first frames are drawn. Either
    /// is one line here. Some tens of ms, once per job.
    pub fn check_with_ffmpeg(&self) -> Result<(), RenderError> {
        self.validate()?;
        let mut cmd = Command::new(&self.ffmpeg);
        cmd.args(["-nostdin", "-hide_banner", "-loglevel", "warning"])
            .args(["-f", "rawvideo", "-pix_fmt", "yuv420p", "-s", "64x64"])
            .args(["-r", "25", "-i", "pipe:0"])
            .args(self.x264_args())
            .args(["-f", "null", "-"])
            .stdin(Stdio::piped())
            .stdout(Stdio::null())
            .stderr(Stdio::piped());
        let mut child = cmd.spawn().map_err(|e| spawn_error(&self.ffmpeg, e))?;
        if let Some(mut stdin) = child.stdin.take() {
            // Black in limited range: Y 16, Cb and Cr 128. A write error
            // means ffmpeg already quit; its status and stderr say why.
            let frame: Vec<u8> = std::iter::repeat_n(16u8, 64 * 64)
                .chain(std::iter::repeat_n(128u8, 64 * 64 / 2))
                .collect();
            let _ = stdin.write_all(&frame);
        }
        let out = child
            .wait_with_output()
            .map_err(|e| spawn_error(&self.ffmpeg, e))?;
        let log = String::from_utf8_lossy(&out.stderr);
        let params = self.x264_params.as_deref().unwrap_or("");
        if let Some(l) = log.lines().find(|l| l.contains("Error parsing option")) {
            let what = l.split("Error parsing option").nth(1).unwrap_or("").trim();
            return Err(RenderError::Params(format!(
                "x264_params '{params}': x264 does not take option {}",
                what.trim_end_matches('.')
            )));
        }
        if log.contains("Unknown encoder") {
            return Err(RenderError::Ffmpeg {
                path: self.ffmpeg.clone(),
                message: "this ffmpeg has no libx264 encoder; install one that has (Debian's: apt-get install ffmpeg)".into(),
            });
        }
        if !out.status.success() {
            let why = log
                .lines()
                .find(|l| l.contains("[libx264"))
                .or_else(|| log.lines().find(|l| !l.trim().is_empty()))
                .unwrap_or("no message");
            // "[libx264 @ 0x55...] qp not specified": the message alone.
            let why = why.split_once("] ").map_or(why, |(_, m)| m).trim();
            return Err(RenderError::Params(format!(
                "x264 refuses these encoder settings (preset {}, x264_params '{params}'): {why}",
                self.preset,
            )));
        }
        Ok(())
    }
}

/// A running ffmpeg child that accepts yuv420p frames.
pub struct Encoder {
    child: Option<Child>,
    stdin: Option<ChildStdin>,
    tmp: PathBuf,
    target: PathBuf,
    frame_bytes: usize,
    done: bool,
    /// `tmp` listed for the binary's Ctrl-C handler to remove.
    _listed: eyereplay_core::inflight::InFlight,
    /// FFmpeg, listed for that handler to kill first; taken off the list
    /// before anything reaps it (a reaped pid may be another process's).
    child_listed: Option<eyereplay_core::inflight::ChildInFlight>,
}

pub fn tmp_path_for(target: &Path) -> PathBuf {
    let name = target
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out.mp4".into());
    target.with_file_name(format!(".{name}.{}.part", std::process::id()))
}

/// Turns a spawn error into the one-line "install ffmpeg" message.
pub fn spawn_error(program: &Path, e: std::io::Error) -> RenderError {
    if e.kind() == std::io::ErrorKind::NotFound {
        RenderError::FfmpegMissing {
            program: program.display().to_string(),
        }
    } else {
        RenderError::Ffmpeg {
            path: program.into(),
            message: format!("cannot start: {e}"),
        }
    }
}

impl Encoder {
    pub fn start(
        target: &Path,
        width: usize,
        height: usize,
        fps: f64,
        settings: &EncoderSettings,
    ) -> Result<Encoder, RenderError> {
        // A stop (Ctrl-C) finds the encoder not begun, or begun and listed.
        eyereplay_core::inflight::guarded(|| {
            Self::start_unguarded(target, width, height, fps, settings)
        })
    }

    fn start_unguarded(
        target: &Path,
        width: usize,
        height: usize,
        fps: f64,
        settings: &EncoderSettings,
    ) -> Result<Encoder, RenderError> {
        if (width | height) & 1 != 0 || width == 0 || height == 0 {
            return Err(RenderError::Params(format!(
                "video size must be even and non-zero for yuv420p, got {width}x{height}"
            )));
        }
        let dir = match target.parent() {
            Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
            _ => PathBuf::from("."),
        };
        std::fs::create_dir_all(&dir).map_err(|e| RenderError::io(&dir, e))?;
        let tmp = tmp_path_for(target);
        // Check we can write there before starting a process.
        std::fs::File::create(&tmp).map_err(|e| RenderError::io(target, e))?;
        let listed = eyereplay_core::inflight::InFlight::new(&tmp);
        let mut cmd = Command::new(&settings.ffmpeg);
        cmd.args(["-nostdin", "-hide_banner", "-loglevel", "error", "-y"])
            .args(["-f", "rawvideo", "-pix_fmt", "yuv420p"])
            .args(["-s", &format!("{width}x{height}")])
            .args(["-r", &fps_arg(fps)])
            .args(["-i", "pipe:0"])
            .args(settings.x264_args());
        cmd.args(["-pix_fmt", "yuv420p"])
            .args(["-color_primaries", "bt709", "-color_trc", "bt709"])
            .args(["-colorspace", "bt709", "-color_range", "tv"])
            .args(["-movflags", "+faststart", "-f", "mp4"])
            .arg(&tmp)
            .stdin(Stdio::piped())
            .stdout(Stdio::null())
            .stderr(Stdio::piped());
        let mut child = match cmd.spawn() {
            Ok(c) => c,
            Err(e) => {
                let _ = std::fs::remove_file(&tmp);
                return Err(spawn_error(&settings.ffmpeg, e));
            }
        };
        let child_listed = eyereplay_core::inflight::ChildInFlight::new(child.id());
        let stdin = child.stdin.take();
        if let Some(pipe) = &stdin {
            grow_pipe(pipe, width * height * 3 / 2);
        }
        Ok(Encoder {
            child: Some(child),
            stdin,
            tmp,
            target: target.to_path_buf(),
            frame_bytes: width * height * 3 / 2,
            done: false,
            _listed: listed,
            child_listed: Some(child_listed),
        })
    }

    pub fn frame_bytes(&self) -> usize {
        self.frame_bytes
    }

    /// Sends one yuv420p frame.
    pub fn write_frame(&mut self, yuv: &[u8]) -> Result<(), RenderError> {
        // Every render path's frames pass here: the one place a stop
        // asked for (the Python package's Ctrl-C) is heard.
        eyereplay_core::cancel::check()?;
        debug_assert_eq!(yuv.len(), self.frame_bytes);
        let stdin = self.stdin.as_mut().expect("encoder already finished");
        if let Err(e) = stdin.write_all(yuv) {
            // A broken pipe means ffmpeg died; its stderr says why.
            let msg = self.fail_message();
            return Err(RenderError::Ffmpeg {
                path: self.target.clone(),
                message: if msg.is_empty() { e.to_string() } else { msg },
            });
        }
        Ok(())
    }

    fn fail_message(&mut self) -> String {
        self.stdin.take();
        let mut msg = String::new();
        if let Some(child) = self.take_child() {
            if let Ok(out) = child.wait_with_output() {
                msg = String::from_utf8_lossy(&out.stderr)
                    .lines()
                    .rfind(|l| !l.trim().is_empty())
                    .unwrap_or("")
                    .to_string();
            }
        }
        msg
    }

    /// Closes the input, waits for ffmpeg, and moves the file into place.
    pub fn finish(self) -> Result<(), RenderError> {
        // A stop (Ctrl-C) waits for the file to be in place.
        eyereplay_core::inflight::guarded(|| self.finish_unguarded())
    }

    /// FFmpeg, taken off the stop's list first: whoever takes it reaps it,
    /// and a stop must not signal a pid that may then be another process's.
    fn take_child(&mut self) -> Option<std::process::Child> {
        self.child_listed.take();
        self.child.take()
    }

    fn finish_unguarded(mut self) -> Result<(), RenderError> {
        self.stdin.take();
        let child = self.take_child().expect("encoder already finished");
        let out = child.wait_with_output().map_err(|e| RenderError::Ffmpeg {
            path: self.target.clone(),
            message: e.to_string(),
        })?;
        if !out.status.success() {
            let msg = String::from_utf8_lossy(&out.stderr)
                .lines()
                .rfind(|l| !l.trim().is_empty())
                .unwrap_or("")
                .to_string();
            return Err(RenderError::Ffmpeg {
                path: self.target.clone(),
                message: format!("exit {}: {msg}", out.status),
            });
        }
        std::fs::rename(&self.tmp, &self.target).map_err(|e| RenderError::io(&self.target, e))?;
        self.done = true;
        Ok(())
    }
}

impl Drop for Encoder {
    fn drop(&mut self) {
        if !self.done {
            self.stdin.take();
            if let Some(mut c) = self.take_child() {
                let _ = c.kill();
                let _ = c.wait();
            }
            // Guarded: once a stop has begun (it killed FFmpeg, which is
            // why this encoder failed) the stop removes the file and
            // reports it, and this waits for the process to end.
            eyereplay_core::inflight::guarded(|| {
                let _ = std::fs::remove_file(&self.tmp);
            });
        }
    }
}

/// Enlarges the pipe to ffmpeg to hold a whole frame where the OS allows
/// it: with the default 64 KiB, every 1.4 MB frame took some twenty
/// writer/reader wake-ups. Best effort; failure only costs speed.
#[cfg(target_os = "linux")]
fn grow_pipe(pipe: &ChildStdin, bytes: usize) {
    use std::os::fd::AsRawFd;
    let want = bytes.next_power_of_two().min(1 << 20) as libc::c_int;
    // SAFETY: fcntl on a file descriptor we own; F_SETPIPE_SZ takes an int
    // and changes nothing but the pipe's capacity.
    unsafe {
        libc::fcntl(pipe.as_raw_fd(), libc::F_SETPIPE_SZ, want);
    }
}

#[cfg(not(target_os = "linux"))]
fn grow_pipe(_pipe: &ChildStdin, _bytes: usize) {}

/// Frame rate as ffmpeg wants it: exact rational for common rates.
fn fps_arg(fps: f64) -> String {
    if (fps - fps.round()).abs() < 1e-9 {
        format!("{}", fps.round() as u64)
    } else if (fps * 1001.0 / 1000.0 - (fps * 1001.0 / 1000.0).round()).abs() < 1e-6 {
        format!("{}/1001", (fps * 1001.0).round() as u64)
    } else {
        format!("{}/1000", (fps * 1000.0).round() as u64)
    }
}

/// What ffprobe reports about a video's first stream.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct VideoInfo {
    pub width: u32,
    pub height: u32,
    pub fps: f64,
    pub frames: u64,
    pub pix_fmt: String,
    pub codec: String,
    pub color_primaries: String,
}

/// Probes a video with ffprobe (packets are counted, not decoded: fast).
pub fn probe_video(path: &Path, ffprobe: &Path) -> Result<VideoInfo, RenderError> {
    let out = Command::new(ffprobe)
        .args(["-v", "error", "-select_streams", "v:0", "-count_packets"])
        .args([
            "-show_entries",
            "stream=codec_name,width,height,r_frame_rate,nb_read_packets,pix_fmt,color_primaries",
            "-of",
            "default=noprint_wrappers=1",
        ])
        .arg(path)
        .stdin(Stdio::null())
        .output()
        .map_err(|e| {
            if e.kind() == std::io::ErrorKind::NotFound {
                RenderError::FfmpegMissing {
                    program: ffprobe.display().to_string(),
                }
            } else {
                RenderError::io(ffprobe, e)
            }
        })?;
    let text = String::from_utf8_lossy(&out.stdout);
    if !out.status.success() || text.trim().is_empty() {
        return Err(RenderError::Probe {
            path: path.into(),
            message: String::from_utf8_lossy(&out.stderr)
                .trim()
                .lines()
                .last()
                .unwrap_or("no video stream")
                .to_string(),
        });
    }
    let get = |k: &str| {
        text.lines()
            .find_map(|l| l.strip_prefix(&format!("{k}=")))
            .unwrap_or("")
            .to_string()
    };
    let bad = |m: &str| RenderError::Probe {
        path: path.into(),
        message: m.into(),
    };
    let rate = get("r_frame_rate");
    let fps = match rate.split_once('/') {
        Some((a, b)) => {
            a.parse::<f64>().map_err(|_| bad("bad rate"))?
                / b.parse::<f64>().map_err(|_| bad("bad rate"))?
        }
        None => rate.parse().map_err(|_| bad("bad rate"))?,
    };
    Ok(VideoInfo {
        width: get("width").parse().map_err(|_| bad("bad width"))?,
        height: get("height").parse().map_err(|_| bad("bad height"))?,
        fps,
        frames: get("nb_read_packets")
            .parse()
            .map_err(|_| bad("bad frame count"))?,
        pix_fmt: get("pix_fmt"),
        codec: get("codec_name"),
        color_primaries: get("color_primaries"),
    })
}

/// ffprobe beside a given ffmpeg (same directory), else on PATH.
pub fn ffprobe_for(ffmpeg: &Path) -> PathBuf {
    match ffmpeg.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.join("ffprobe"),
        _ => PathBuf::from("ffprobe"),
    }
}
