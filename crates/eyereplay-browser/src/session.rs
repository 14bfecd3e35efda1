//! One session through the browser: capture frames, decode them, encode
//! them with the renderer's x264 encoder, and write the truth CSV.

use crate::capture::Capture;
use crate::settings::{BrowserSettings, ImageFormat};
use crate::BrowserError;
use eyereplay_core::{CanvasPos, CoreError};
use eyereplay_render::{rgb_to_yuv420, Encoder, EncoderSettings};
use serde_json::Value;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::Instant;

/// What one browser-rendered session did.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct BrowserSessionStats {
    /// The session's name (the video's file stem).
    pub session: String,
    pub frames: usize,
    /// Trajectory points outside the canvas, clamped onto its edge.
    pub clamped_points: usize,
    /// Mapped points outside the viewport, clamped onto its edge.
    pub clamped_page_points: usize,
    /// Frames where the page did not redraw and the previous picture was
    /// repeated (the browser sends no screenshot without damage).
    pub unchanged_frames: usize,
    pub width: usize,
    pub height: usize,
    /// Browser start, page load and readiness, s.
    pub startup_s: f64,
    /// Capture, decode and encode of all frames, s.
    pub capture_s: f64,
    pub total_s: f64,
    pub browser_version: String,
    /// The URL loaded.
    pub url: String,
}

impl BrowserSessionStats {
    /// Frames per second of the frame loop (capture + encode).
    pub fn capture_fps(&self) -> f64 {
        self.frames as f64 / self.capture_s.max(1e-9)
    }
}

/// Screenshot bytes -> RGB (whole viewport); a screenshot that does not
/// decode is a [`BrowserError::Image`].
pub fn decode_image(
    bytes: &[u8],
    format: ImageFormat,
) -> Result<(Vec<u8>, usize, usize), BrowserError> {
    match format {
        ImageFormat::Jpeg => {
            use zune_jpeg::zune_core::{
                bytestream::ZCursor, colorspace::ColorSpace, options::DecoderOptions,
            };
            let opts = DecoderOptions::default().jpeg_set_out_colorspace(ColorSpace::RGB);
            let mut d = zune_jpeg::JpegDecoder::new_with_options(ZCursor::new(bytes), opts);
            let rgb = d
                .decode()
                .map_err(|e| BrowserError::Image(format!("bad JPEG: {e:?}")))?;
            let info = d
                .info()
                .ok_or_else(|| BrowserError::Image("JPEG without size".into()))?;
            Ok((rgb, info.width as usize, info.height as usize))
        }
        ImageFormat::Png => {
            let mut dec = png::Decoder::new(bytes);
            dec.set_transformations(png::Transformations::normalize_to_color8());
            let mut r = dec
                .read_info()
                .map_err(|e| BrowserError::Image(format!("bad PNG: {e}")))?;
            let mut buf = vec![0; r.output_buffer_size()];
            let info = r
                .next_frame(&mut buf)
                .map_err(|e| BrowserError::Image(format!("bad PNG: {e}")))?;
            let (w, h) = (info.width as usize, info.height as usize);
            buf.truncate(info.buffer_size());
            let rgb = match info.color_type {
                png::ColorType::Rgb => buf,
                png::ColorType::Rgba => buf
                    .chunks_exact(4)
                    .flat_map(|p| [p[0], p[1], p[2]])
                    .collect(),
                png::ColorType::Grayscale => buf.iter().flat_map(|&g| [g, g, g]).collect(),
                png::ColorType::GrayscaleAlpha => buf
                    .chunks_exact(2)
                    .flat_map(|p| [p[0], p[0], p[0]])
                    .collect(),
                png::ColorType::Indexed => {
                    return Err(BrowserError::Image("indexed PNG after expansion".into()))
                }
            };
            Ok((rgb, w, h))
        }
    }
}

/// Turns screenshots into yuv420p frames of the video size.
struct FrameConverter {
    format: ImageFormat,
    viewport: (usize, usize),
    /// x, y, width, height of the video inside the viewport.
    crop: (usize, usize, usize, usize),
    cropped: Vec<u8>,
}

impl FrameConverter {
    fn new(settings: &BrowserSettings) -> Self {
        let viewport = (
            settings.viewport_px[0] as usize,
            settings.viewport_px[1] as usize,
        );
        let crop = match settings.crop {
            Some(c) => (
                c.x as usize,
                c.y as usize,
                c.width as usize,
                c.height as usize,
            ),
            None => (0, 0, viewport.0, viewport.1),
        };
        FrameConverter {
            format: settings.format,
            viewport,
            crop,
            cropped: Vec::new(),
        }
    }

    fn convert(&mut self, frame: usize, bytes: &[u8], yuv: &mut [u8]) -> Result<(), BrowserError> {
        let (rgb, w, h) = decode_image(bytes, self.format).map_err(|e| BrowserError::Frame {
            frame,
            message: e.to_string(),
        })?;
        if (w, h) != self.viewport {
            return Err(BrowserError::Frame {
                frame,
                message: format!(
                    "screenshot is {w}x{h}, viewport {}x{}",
                    self.viewport.0, self.viewport.1
                ),
            });
        }
        let (cx, cy, cw, ch) = self.crop;
        let src = if (cw, ch) == (w, h) {
            &rgb
        } else {
            self.cropped.clear();
            for y in cy..cy + ch {
                self.cropped
                    .extend_from_slice(&rgb[(y * w + cx) * 3..(y * w + cx + cw) * 3]);
            }
            &self.cropped
        };
        rgb_to_yuv420(src, cw, [0, 0, cw, ch], yuv, cw, ch);
        Ok(())
    }
}

/// Clamps canvas points onto the canvas and maps them to page px, clamped
/// into the viewport. Returns (canvas points, page points, clamped canvas
/// points, clamped page points).
#[allow(clippy::type_complexity)]
fn map_trajectory(
    settings: &BrowserSettings,
    trajectory: &[CanvasPos],
) -> Result<(Vec<CanvasPos>, Vec<[f64; 2]>, usize, usize), BrowserError> {
    if trajectory.is_empty() {
        return Err(BrowserError::Input("trajectory has no frames".into()));
    }
    let [cw, ch] = settings.mapping.canvas_px.map(|v| v as f64);
    let [vw, vh] = settings.viewport_px.map(|v| v as f64);
    let (mut clamped, mut clamped_page) = (0, 0);
    let mut canvas = Vec::with_capacity(trajectory.len());
    let mut page = Vec::with_capacity(trajectory.len());
    for (i, p) in trajectory.iter().enumerate() {
        if !(p.x_px.is_finite() && p.y_px.is_finite()) {
            return Err(BrowserError::Input(format!(
                "trajectory frame {i} is not a finite position"
            )));
        }
        let c = CanvasPos {
            x_px: p.x_px.clamp(0.0, cw),
            y_px: p.y_px.clamp(0.0, ch),
        };
        clamped += (c != *p) as usize;
        let q = settings.mapping.to_page(c);
        // The last pixel's far edge is outside the page.
        let r = [
            q[0].clamp(0.0, vw - 1.0 / 16.0),
            q[1].clamp(0.0, vh - 1.0 / 16.0),
        ];
        clamped_page += (r != q) as usize;
        canvas.push(c);
        page.push(r);
    }
    Ok((canvas, page, clamped, clamped_page))
}

/// The session's name: the video's file stem.
pub fn session_name(out_mp4: &Path) -> String {
    out_mp4
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| out_mp4.display().to_string())
}

/// Renders one session through the browser: `trajectory` (canvas px, one
/// point per frame) at `fps` to `out_mp4` (H.264 through the renderer's
/// encoder with `encoder`'s settings) and `out_truth_csv`.
///
/// The truth CSV has one row per frame: `frame`, `x`, `y` (canvas px after
/// clamping, 3 decimals), `page_x`, `page_y` (where the mouse was put, page
/// px, 3 decimals), then the columns of `settings.truth_js` if set.
///
/// On any error nothing is left under either name, the browser's process
/// group is gone and its profile folder removed; the error names the
/// session.
pub fn render_session_browser(
    settings: &BrowserSettings,
    encoder: &EncoderSettings,
    trajectory: &[CanvasPos],
    fps: f64,
    out_mp4: &Path,
    out_truth_csv: &Path,
) -> Result<BrowserSessionStats, BrowserError> {
    let name = session_name(out_mp4);
    render_inner(
        settings,
        encoder,
        trajectory,
        fps,
        out_mp4,
        out_truth_csv,
        &name,
    )
    .map_err(|e| e.in_session(&name))
}

fn render_inner(
    settings: &BrowserSettings,
    encoder_settings: &EncoderSettings,
    trajectory: &[CanvasPos],
    fps: f64,
    out_mp4: &Path,
    out_truth_csv: &Path,
    name: &str,
) -> Result<BrowserSessionStats, BrowserError> {
    let t_start = Instant::now();
    settings.validate()?;
    let (canvas, page, clamped, clamped_page) = map_trajectory(settings, trajectory)?;
    let mut cap = Capture::open(settings, fps)?;
    let startup_s = t_start.elapsed().as_secs_f64();
    let (w, h) = settings.video_size();
    let mut encoder = Encoder::start(out_mp4, w, h, fps, encoder_settings)?;

    // Decoding and encoding run beside the capture: the browser renders the
    // next frame while this one is converted.
    let (tx, rx) = mpsc::sync_channel::<(usize, Vec<u8>)>(4);
    let mut conv = FrameConverter::new(settings);
    let worker = std::thread::Builder::new()
        .name(format!("encode-{name}"))
        .spawn(move || -> Result<Encoder, BrowserError> {
            let mut yuv = vec![0u8; encoder.frame_bytes()];
            for (i, bytes) in rx {
                conv.convert(i, &bytes, &mut yuv)?;
                encoder.write_frame(&yuv)?;
            }
            Ok(encoder)
        })
        .map_err(|e| BrowserError::io(out_mp4, e))?;

    // Object.entries keeps the page's key order (serde_json's map sorts).
    let truth_expr = settings.truth_js.as_ref().map(|js| {
        format!(
            "(() => {{ const o = ({js}); return (o && typeof o === 'object' && !Array.isArray(o)) ? Object.entries(o) : o; }})()"
        )
    });
    let t_capture = Instant::now();
    let mut truth_cols: Option<Vec<String>> = None;
    let mut truth_rows: Vec<Vec<f64>> = Vec::new();
    let mut unchanged = 0;
    let captured: Result<(), BrowserError> = (|| {
        for (i, pos) in page.iter().enumerate() {
            let shot = cap.frame(*pos).map_err(|e| match e {
                BrowserError::Frame { message, .. } => BrowserError::Frame { frame: i, message },
                e => e,
            })?;
            unchanged += (!shot.fresh) as usize;
            if let Some(js) = &truth_expr {
                let v = cap.eval(js).map_err(|e| match e {
                    BrowserError::Protocol { message, .. } => BrowserError::Truth {
                        frame: i,
                        message: format!("threw {message}"),
                    },
                    e => e,
                })?;
                truth_rows.push(truth_row(&v, i, &mut truth_cols)?);
            }
            if tx.send((i, shot.image)).is_err() {
                // The worker stopped: its error is reported below.
                break;
            }
        }
        Ok(())
    })();
    drop(tx);
    let encoded = worker.join().unwrap_or_else(|_| {
        Err(BrowserError::Frame {
            frame: 0,
            message: "encoder thread panicked".into(),
        })
    });
    let browser_version = cap.browser_version.clone();
    let url = cap.url().to_string();
    cap.close();
    captured?;
    // The encoder's temporary file is removed when it is dropped unfinished.
    let encoder = encoded?;
    encoder.finish()?;
    let capture_s = t_capture.elapsed().as_secs_f64();
    if let Err(e) = write_truth(
        out_truth_csv,
        &canvas,
        &page,
        truth_cols.as_deref().unwrap_or(&[]),
        &truth_rows,
    ) {
        let _ = std::fs::remove_file(out_mp4);
        return Err(e.into());
    }
    Ok(BrowserSessionStats {
        session: name.to_string(),
        frames: canvas.len(),
        clamped_points: clamped,
        clamped_page_points: clamped_page,
        unchanged_frames: unchanged,
        width: w,
        height: h,
        startup_s,
        capture_s,
        total_s: t_start.elapsed().as_secs_f64(),
        browser_version,
        url,
    })
}

/// One row of `truth_js` values, given as `[key, value]` pairs in the
/// page's key order; the first frame fixes the columns.
fn truth_row(
    v: &Value,
    frame: usize,
    cols: &mut Option<Vec<String>>,
) -> Result<Vec<f64>, BrowserError> {
    let bad = |message: String| BrowserError::Truth { frame, message };
    let not_object = || bad(format!("expected an object of numbers, got {v}"));
    let pairs = v.as_array().ok_or_else(not_object)?;
    let mut keys = Vec::with_capacity(pairs.len());
    let mut values = Vec::with_capacity(pairs.len());
    for p in pairs {
        let (Some(k), Some(val)) = (p.get(0).and_then(Value::as_str), p.get(1)) else {
            return Err(not_object());
        };
        keys.push(k.to_string());
        values.push(match val {
            Value::Number(n) => n
                .as_f64()
                .ok_or_else(|| bad(format!("{k} is not a number")))?,
            Value::Bool(b) => *b as u8 as f64,
            other => return Err(bad(format!("{k} is {other}, not a number"))),
        });
    }
    match cols {
        None => {
            if let Some(k) = keys.iter().find(|k| {
                k.is_empty()
                    || k.contains([',', '"', '\n', '\r'])
                    || ["frame", "x", "y", "page_x", "page_y"].contains(&k.as_str())
            }) {
                return Err(bad(format!("column name {k:?} is not allowed")));
            }
            *cols = Some(keys);
        }
        Some(c) if *c != keys => {
            return Err(bad(format!(
                "columns {keys:?} differ from the first frame's {c:?}"
            )))
        }
        Some(_) => {}
    }
    Ok(values)
}

/// Writes the truth CSV atomically. Page columns keep 6 decimals (whole
/// numbers are written without), which keeps reruns byte-identical.
fn write_truth(
    path: &Path,
    canvas: &[CanvasPos],
    page: &[[f64; 2]],
    cols: &[String],
    rows: &[Vec<f64>],
) -> Result<(), CoreError> {
    eyereplay_core::atomic_write_with(path, |w| {
        let mut header = String::from("frame,x,y,page_x,page_y");
        for c in cols {
            header.push(',');
            header += c;
        }
        writeln!(w, "{header}")?;
        let mut line = Vec::with_capacity(256);
        for (i, (c, p)) in canvas.iter().zip(page).enumerate() {
            line.clear();
            eyereplay_core::push_point_row(&mut line, i as u64, *c);
            write!(line, ",{:.3},{:.3}", p[0], p[1])?;
            for v in rows.get(i).map(Vec::as_slice).unwrap_or(&[]) {
                if v.fract() == 0.0 && v.abs() < 1e15 {
                    write!(line, ",{}", *v as i64)?;
                } else {
                    write!(line, ",{v:.6}")?;
                }
            }
            line.push(b'\n');
            w.write_all(&line)?;
        }
        Ok(())
    })
}

/// One session of a batch.
#[derive(Clone, Debug)]
pub struct BrowserJob {
    pub trajectory: Vec<CanvasPos>,
    pub fps: f64,
    pub out_mp4: PathBuf,
    pub out_truth_csv: PathBuf,
}

/// Renders sessions in parallel, one browser per running session, at most
/// `jobs` at once (0: one per two cores, since each browser keeps about two
/// cores busy with its own renderer and compositor). Results are in the
/// order of `sessions`; one failing session does not stop the others.
pub fn render_sessions(
    settings: &BrowserSettings,
    encoder: &EncoderSettings,
    sessions: &[BrowserJob],
    jobs: usize,
) -> Vec<Result<BrowserSessionStats, BrowserError>> {
    use rayon::prelude::*;
    let n = if jobs == 0 {
        std::thread::available_parallelism()
            .map(|n| (n.get() / 2).max(1))
            .unwrap_or(1)
    } else {
        jobs
    };
    let run = || {
        sessions
            .par_iter()
            .map(|j| {
                render_session_browser(
                    settings,
                    encoder,
                    &j.trajectory,
                    j.fps,
                    &j.out_mp4,
                    &j.out_truth_csv,
                )
            })
            .collect()
    };
    match rayon::ThreadPoolBuilder::new().num_threads(n).build() {
        Ok(pool) => pool.install(run),
        Err(_) => run(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mapping_mirrors_scales_and_clamps() {
        let mut s = BrowserSettings::default();
        s.mapping.mirror_x = true;
        s.mapping.scale = [0.5, 0.5];
        s.mapping.offset_px = [100.0, 10.0];
        let traj = [
            CanvasPos {
                x_px: 0.0,
                y_px: 0.0,
            },
            CanvasPos {
                x_px: 1280.0,
                y_px: 720.0,
            },
            CanvasPos {
                x_px: -5.0,
                y_px: 800.0,
            },
        ];
        let (c, p, clamped, clamped_page) = map_trajectory(&s, &traj).unwrap();
        // Mirrored: canvas x 0 is page x 100 + 0.5 * 1280.
        assert_eq!(p[0], [740.0, 10.0]);
        assert_eq!(p[1], [100.0, 370.0]);
        assert_eq!(
            c[2],
            CanvasPos {
                x_px: 0.0,
                y_px: 720.0
            }
        );
        assert_eq!((clamped, clamped_page), (1, 0));
        s.mapping = Default::default();
        s.mapping.offset_px = [200.0, 0.0];
        let (_, p, _, clamped_page) = map_trajectory(&s, &traj[1..2]).unwrap();
        assert_eq!(p[0], [1280.0 - 1.0 / 16.0, 720.0 - 1.0 / 16.0]);
        assert_eq!(clamped_page, 1);
    }

    #[test]
    fn truth_rows_keep_their_columns() {
        use serde_json::json;
        let mut cols = None;
        let r = truth_row(&json!([["b", 1.5], ["a", true]]), 0, &mut cols).unwrap();
        assert_eq!(r, vec![1.5, 1.0]);
        assert_eq!(cols, Some(vec!["b".to_string(), "a".to_string()]));
        let e = truth_row(&json!([["a", 1], ["b", 2]]), 1, &mut cols).unwrap_err();
        assert!(e.to_string().contains("frame 1"), "{e}");
        assert!(truth_row(&json!(null), 2, &mut cols).is_err());
        assert!(truth_row(&json!([["b", "x"], ["a", 1]]), 2, &mut cols).is_err());
        let mut cols = None;
        assert!(truth_row(&json!([["x", 1]]), 0, &mut cols).is_err());
    }

    #[test]
    fn settings_parse_with_defaults_and_reject_unknown_fields() {
        let s: BrowserSettings = serde_json::from_str(
            r#"{"url": "http://127.0.0.1:8000/", "mapping": {"mirror_x": true},
                "ready": {"selector": "canvas"}, "crop": {"x": 0, "y": 0, "width": 640, "height": 360}}"#,
        )
        .unwrap();
        assert!(s.mapping.mirror_x && s.mapping.scale == [1.0, 1.0]);
        assert_eq!(s.ready.timeout_s, 30.0);
        assert_eq!(s.video_size(), (640, 360));
        s.validate().unwrap();
        let e = serde_json::from_str::<BrowserSettings>(r#"{"urll": "x"}"#).unwrap_err();
        assert!(e.to_string().contains("unknown field"), "{e}");
        let s = BrowserSettings {
            crop: Some(crate::CropPx {
                x: 1000,
                y: 0,
                width: 640,
                height: 360,
            }),
            ..Default::default()
        };
        assert!(s.validate().is_err());
    }
}
