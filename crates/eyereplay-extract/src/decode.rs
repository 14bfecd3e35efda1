//! Video decoding with ffmpeg (libav* through `ffmpeg-next`), frame by frame
//! with each frame's own presentation time, so variable-frame-rate input
//! keeps its real timing: `time_s = best_effort_timestamp x time_base`,
//! exactly what ffprobe reports as `pts_time`.

use crate::error::{ExtractError, Result};
use crate::image::{ImageView, Planes, Rotation, YuvMatrix};
use ffmpeg_next as ff;
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};

/// What is known about a video before decoding it.
#[derive(Clone, Debug, PartialEq)]
pub struct VideoInfo {
    /// Upright size (after rotation metadata).
    pub width: usize,
    pub height: usize,
    pub rotation: Rotation,
    /// Stream start and duration in seconds, when the container says.
    pub start_s: f64,
    pub duration_s: Option<f64>,
    /// Frame count, from the container or duration x average rate.
    pub frames_estimate: Option<u64>,
    pub avg_fps: Option<f64>,
    pub codec: String,
}

fn init() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let _ = ff::init();
        // FFmpeg's own log lines off: corrupt-frame chatter goes through
        // our own error count, and a file that is not a video gets our
        // one-line error. (At `Fatal`, Debian's FFmpeg 5.1 still printed
        // "[mjpeg @ ...] No JPEG data found in image" for a non-image.)
        ff::util::log::set_level(ff::util::log::Level::Quiet);
    });
}

fn rational(r: ff::Rational) -> Option<f64> {
    (r.denominator() != 0 && r.numerator() != 0)
        .then(|| r.numerator() as f64 / r.denominator() as f64)
}

/// An open video: demuxer, decoder and the stream's facts.
pub struct Decoder {
    path: PathBuf,
    ictx: ff::format::context::Input,
    stream: usize,
    time_base: f64,
    decoder: ff::decoder::Video,
    scaler: Option<(ff::software::scaling::Context, ff::frame::Video)>,
    pub info: VideoInfo,
    /// Packets or frames the decoder rejected (corrupt data).
    pub errors: u64,
}

impl Decoder {
    pub fn open(path: &Path) -> Result<Decoder> {
        Self::from_input(path, open_file(path)?)
    }

    /// Opens a stream that is not a file: `pipe:0` (standard input, in any
    /// container FFmpeg reads from a pipe: NUT, Matroska, MPEG-TS),
    /// `pipe:N` (an inherited descriptor), or a network URL (`rtsp://`,
    /// `http://`...). Frames come out as they arrive. `interrupt` is FFmpeg's
    /// interrupt callback: asked while the stream is opened and whenever a
    /// read waits (a network protocol asks it every 100 ms or so; a pipe
    /// when a signal cuts its read short), `true` ends the wait, and the
    /// stream then ends as at its end of file ([`Decoder::frames`] returns
    /// the frames it had). How a live watch stops on Ctrl-C, or gives up on
    /// a stream that stalled; `|| false` waits as long as it takes.
    pub fn open_url(
        url: &str,
        interrupt: impl FnMut() -> bool + Send + 'static,
    ) -> Result<Decoder> {
        init();
        let path = Path::new(url);
        let ictx =
            ff::format::input_with_interrupt(&path, interrupt).map_err(|e| ExtractError::Open {
                path: path.to_path_buf(),
                message: e.to_string(),
            })?;
        Self::from_input(path, ictx)
    }

    fn from_input(path: &Path, ictx: ff::format::context::Input) -> Result<Decoder> {
        let open_err = |e: ff::Error| ExtractError::Open {
            path: path.to_path_buf(),
            message: e.to_string(),
        };
        let st = ictx.streams().best(ff::media::Type::Video).ok_or_else(|| {
            ExtractError::NoVideoStream {
                path: path.to_path_buf(),
            }
        })?;
        let stream = st.index();
        let tb = st.time_base();
        let time_base = rational(tb).unwrap_or(0.0);
        let ctx =
            ff::codec::context::Context::from_parameters(st.parameters()).map_err(open_err)?;
        let codec = ctx.id();
        // FFmpeg's own words, "Decoder not found", named neither the
        // codec nor that this build lacks it (the Python wheel's FFmpeg
        // has no AV1, say).
        let decoder = ctx.decoder().video().map_err(|e| match e {
            ff::Error::DecoderNotFound => ExtractError::Open {
                path: path.to_path_buf(),
                message: format!(
                    "no decoder for its {} video in this build's FFmpeg (convert it to H.264: \
                     ffmpeg -i IN -c:v libx264 OUT.mp4)",
                    format!("{codec:?}").to_lowercase()
                ),
            },
            e => open_err(e),
        })?;
        let rotation = display_rotation(&st);
        let (rw, rh) = (decoder.width() as usize, decoder.height() as usize);
        if rw == 0 || rh == 0 {
            return Err(ExtractError::Open {
                path: path.to_path_buf(),
                message: "video stream has no picture size".into(),
            });
        }
        let (width, height) = match rotation {
            Rotation::Cw90 | Rotation::Cw270 => (rh, rw),
            _ => (rw, rh),
        };
        let start_s = if st.start_time() != ff::ffi::AV_NOPTS_VALUE {
            st.start_time() as f64 * time_base
        } else {
            0.0
        };
        let duration_s = if st.duration() > 0 {
            Some(st.duration() as f64 * time_base)
        } else if ictx.duration() > 0 {
            Some(ictx.duration() as f64 / ff::ffi::AV_TIME_BASE as f64)
        } else {
            None
        };
        let avg_fps = rational(st.avg_frame_rate()).or_else(|| rational(st.rate()));
        let frames_estimate = if st.frames() > 0 {
            Some(st.frames() as u64)
        } else {
            duration_s.zip(avg_fps).map(|(d, f)| (d * f).round() as u64)
        };
        let info = VideoInfo {
            width,
            height,
            rotation,
            start_s,
            duration_s,
            frames_estimate,
            avg_fps,
            codec: format!("{codec:?}").to_lowercase(),
        };
        Ok(Decoder {
            path: path.to_path_buf(),
            ictx,
            stream,
            time_base,
            decoder,
            scaler: None,
            info,
            errors: 0,
        })
    }

    /// Positions the demuxer at the last keyframe at or before `t_s`
    /// (seconds on the stream's clock). Frames before `t_s` still come out
    /// of [`Decoder::frames`]; the caller skips them by time.
    pub fn seek_s(&mut self, t_s: f64) -> Result<()> {
        let ts = (t_s * ff::ffi::AV_TIME_BASE as f64).floor() as i64;
        self.ictx.seek(ts, ..ts).map_err(|e| ExtractError::Decode {
            path: self.path.clone(),
            message: format!("seek to {t_s:.3} s failed: {e}"),
        })?;
        self.decoder.flush();
        Ok(())
    }

    /// The presentation time of the keyframe a seek to `t_s` lands on,
    /// read from the first packet after the seek, without decoding: `None`
    /// when that packet is no keyframe, has no timestamp, or lies after
    /// `t_s` (a container whose index does not allow an exact seek).
    pub fn keyframe_before_s(&mut self, t_s: f64) -> Result<Option<f64>> {
        self.seek_s(t_s)?;
        let mut packet = ff::Packet::empty();
        // Other streams' packets (audio) may come first.
        for _ in 0..256 {
            match packet.read(&mut self.ictx) {
                Ok(()) => {}
                Err(ff::Error::Eof) => return Ok(None),
                Err(ff::Error::InvalidData) => continue,
                Err(e) => {
                    return Err(ExtractError::Decode {
                        path: self.path.clone(),
                        message: e.to_string(),
                    })
                }
            }
            if packet.stream() != self.stream {
                continue;
            }
            let t = packet
                .pts()
                .filter(|_| self.time_base > 0.0)
                .map(|pts| pts as f64 * self.time_base);
            return Ok(t.filter(|&t| packet.is_key() && t <= t_s));
        }
        Ok(None)
    }

    /// Decodes frames in presentation order, calling `f(time_s, image)` for
    /// each until it breaks or the stream ends. Returns the number of frames.
    pub fn frames(
        &mut self,
        mut f: impl FnMut(f64, &ImageView) -> Result<ControlFlow<()>>,
    ) -> Result<u64> {
        let mut n = 0u64;
        let mut last_t: Option<f64> = None;
        let frame_dt = self.info.avg_fps.map(|r| 1.0 / r).unwrap_or(1.0 / 25.0);
        let mut frame = ff::frame::Video::empty();
        let mut eof = false;
        loop {
            // Receive everything the decoder has before feeding more.
            loop {
                match self.decoder.receive_frame(&mut frame) {
                    Ok(()) => {
                        // Every loop over a video's frames passes here:
                        // the one place a stop asked for (the Python
                        // package's Ctrl-C) is heard while reading.
                        eyereplay_core::cancel::check()?;
                        let t = match frame.timestamp() {
                            Some(ts) if self.time_base > 0.0 => ts as f64 * self.time_base,
                            // No timestamp at all: continue from the last one.
                            _ => last_t.map(|t| t + frame_dt).unwrap_or(self.info.start_s),
                        };
                        last_t = Some(t);
                        n += 1;
                        let flow = self.with_view(&frame, |img| f(t, img))??;
                        if flow.is_break() {
                            return Ok(n);
                        }
                    }
                    Err(ff::Error::Eof) => return Ok(n),
                    Err(ff::Error::Other { errno }) if errno == ff::util::error::EAGAIN => break,
                    Err(_) => {
                        self.errors += 1;
                        break;
                    }
                }
            }
            if eof {
                // Drained after EOF without reaching the decoder's own EOF.
                return Ok(n);
            }
            let mut packet = ff::Packet::empty();
            match packet.read(&mut self.ictx) {
                Ok(()) => {
                    if packet.stream() == self.stream && self.decoder.send_packet(&packet).is_err()
                    {
                        self.errors += 1;
                    }
                }
                // The interrupt callback ended a wait: an end like EOF's.
                Err(ff::Error::Eof | ff::Error::Exit) => {
                    eof = true;
                    let _ = self.decoder.send_eof();
                }
                Err(ff::Error::InvalidData) => self.errors += 1,
                Err(e) => {
                    return Err(ExtractError::Decode {
                        path: self.path.clone(),
                        message: e.to_string(),
                    })
                }
            }
        }
    }

    fn with_view<R>(
        &mut self,
        frame: &ff::frame::Video,
        f: impl FnOnce(&ImageView) -> R,
    ) -> Result<R> {
        use ff::format::Pixel;
        let (w, h) = (frame.width() as usize, frame.height() as usize);
        match frame.format() {
            Pixel::YUV420P | Pixel::YUVJ420P => {
                let full = frame.format() == Pixel::YUVJ420P
                    || frame.color_range() == ff::color::Range::JPEG;
                let bt709 = match frame.color_space() {
                    ff::color::Space::BT709 => true,
                    ff::color::Space::Unspecified => h >= 720,
                    _ => false,
                };
                let view = ImageView {
                    planes: Planes::Yuv420 {
                        y: frame.data(0),
                        u: frame.data(1),
                        v: frame.data(2),
                        y_stride: frame.stride(0),
                        c_stride: frame.stride(1),
                        matrix: YuvMatrix::new(bt709, full),
                    },
                    raw_w: w,
                    raw_h: h,
                    rotation: self.info.rotation,
                };
                Ok(f(&view))
            }
            other => {
                let rebuild = match &self.scaler {
                    Some((s, _)) => {
                        s.input().format != other
                            || s.input().width as usize != w
                            || s.input().height as usize != h
                    }
                    None => true,
                };
                if rebuild {
                    let ctx = ff::software::scaling::Context::get(
                        other,
                        w as u32,
                        h as u32,
                        Pixel::RGB24,
                        w as u32,
                        h as u32,
                        ff::software::scaling::Flags::BILINEAR,
                    )
                    .map_err(|e| ExtractError::Decode {
                        path: self.path.clone(),
                        message: format!("pixel format {other:?}: {e}"),
                    })?;
                    self.scaler = Some((ctx, ff::frame::Video::empty()));
                }
                let (ctx, rgb) = self.scaler.as_mut().expect("scaler set above");
                ctx.run(frame, rgb).map_err(|e| ExtractError::Decode {
                    path: self.path.clone(),
                    message: e.to_string(),
                })?;
                let view = ImageView {
                    planes: Planes::Rgb24 {
                        data: rgb.data(0),
                        stride: rgb.stride(0),
                    },
                    raw_w: w,
                    raw_h: h,
                    rotation: self.info.rotation,
                };
                Ok(f(&view))
            }
        }
    }
}

/// The stream's display-matrix rotation, if any.
fn display_rotation(st: &ff::format::stream::Stream) -> Rotation {
    for sd in st.side_data() {
        if sd.kind() == ff::codec::packet::side_data::Type::DisplayMatrix && sd.data().len() >= 36 {
            // SAFETY: a display matrix is nine int32 (36 bytes), checked above;
            // av_display_rotation_get only reads them.
            let ccw = unsafe { ff::ffi::av_display_rotation_get(sd.data().as_ptr() as *const i32) };
            if ccw.is_finite() {
                return Rotation::from_display_ccw_deg(ccw);
            }
        }
    }
    Rotation::None
}

/// Facts about a video without decoding it.
pub fn probe(path: &Path) -> Result<VideoInfo> {
    Ok(Decoder::open(path)?.info)
}

/// A file's demuxer, or the one-line error naming it.
fn open_file(path: &Path) -> Result<ff::format::context::Input> {
    init();
    if !path.is_file() {
        return Err(ExtractError::Open {
            path: path.to_path_buf(),
            message: if path.is_dir() {
                "is a folder, not a video file".into()
            } else {
                "no such file".into()
            },
        });
    }
    let input = ff::format::input(&path).map_err(|e| ExtractError::Open {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    // FFmpeg's "tty" demuxer plays any text file (.txt, .asc, .nfo, ...)
    // as ANSI art, a "video" of its lines: an eye-tracker export given as
    // a video would otherwise be decoded for minutes and then have no face.
    if input.format().name() == "tty" {
        return Err(ExtractError::Open {
            path: path.to_path_buf(),
            message: "a text file, not a video".into(),
        });
    }
    Ok(input)
}

/// The stored width and height of a file's video stream, from the
/// container's codec parameters (nothing decoded; rotation metadata not
/// applied): what a finished session is checked against.
pub fn video_stream_size(path: &Path) -> Result<(usize, usize)> {
    let ictx = open_file(path)?;
    let st =
        ictx.streams()
            .best(ff::media::Type::Video)
            .ok_or_else(|| ExtractError::NoVideoStream {
                path: path.to_path_buf(),
            })?;
    let open_err = |e: ff::Error| ExtractError::Open {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    let ctx = ff::codec::context::Context::from_parameters(st.parameters()).map_err(open_err)?;
    let v = ctx.decoder().video().map_err(open_err)?;
    Ok((v.width() as usize, v.height() as usize))
}

/// The packets of a file's video stream, counted by demuxing it without
/// decoding: for the H.264 MP4s eyereplay writes, one packet a frame. It
/// reads the whole file, so a cut-off one counts fewer. What `ffprobe
/// -count_packets` reports as `nb_read_packets`, without starting a
/// process (whose dynamic linking of the libav* libraries alone cost
/// about 0.15 CPU-s): a resumed or merged dataset checks every session's
/// video this way.
pub fn count_video_packets(path: &Path) -> Result<u64> {
    let mut ictx = open_file(path)?;
    let stream = ictx
        .streams()
        .best(ff::media::Type::Video)
        .ok_or_else(|| ExtractError::NoVideoStream {
            path: path.to_path_buf(),
        })?
        .index();
    let mut packets = 0u64;
    for (st, _) in ictx.packets() {
        if st.index() == stream {
            packets += 1;
        }
    }
    Ok(packets)
}
