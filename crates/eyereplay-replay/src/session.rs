//! A carrier made ready ([`Carrier::prepare`]) and a whole replay session
//! ([`render_replay_session`]): the carrier's frames in a ping-pong loop,
//! each with its eyes redrawn at the trajectory, encoded to MP4, with the
//! ground truth and the carrier frame of every output frame.

use crate::carrier::{CarrierTrack, CarrierUsage, Skip};
use crate::error::{ReplayError, Result};
use crate::frame::{for_each_planned, nearest_frame, FrameView, RgbFrame};
use crate::redraw::{redraw_eye, AppearanceBuilder, EyeAppearance};
use eyereplay_core::CanvasPos;
use eyereplay_dataset::{EyeTruthRow, TruthRow};
use eyereplay_extract::Decoder;
use eyereplay_render::{
    rgb_to_yuv420, time_bench, BenchReport, BenchShape, Encoder, EncoderSettings, FrameSink,
};
use eyereplay_signal::stats::linear_fit;
use serde::Serialize;
use std::io::Write;
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};

/// Frames the appearance model learns from, at most (spread evenly over
/// the clip's usable frames).
pub const APPEARANCE_FRAMES: usize = 120;

/// Frames either side averaged into a frame's lid geometry.
pub const GEOMETRY_SMOOTHING_HALF: usize = 1;

/// Columns of `<session>_carrier.csv`: which carrier frame each output
/// frame shows, whether its eyes were redrawn (and why not), and the
/// carrier's own gaze in that frame as the extractor read it.
pub const CARRIER_CSV_HEADER: &str = "frame,carrier_frame,carrier_time_s,redrawn,skip,\
face_score,carrier_nx,carrier_ny,left_iris_x_px,left_iris_y_px,right_iris_x_px,right_iris_y_px";

/// The columns of `<session>_carrier.csv` that readers use.
#[derive(Clone, Debug, PartialEq)]
pub struct CarrierCsvRow {
    pub carrier_frame: usize,
    /// False where the frame was left as the carrier shows it.
    pub redrawn: bool,
    pub face_score: f64,
    /// The carrier's own gaze as the extractor read it (`None`: no face).
    pub carrier_n: Option<[f64; 2]>,
}

/// Reads a carrier CSV written by [`render_replay_session`]; errors name
/// the file and line.
pub fn read_carrier_csv(path: &Path) -> Result<Vec<CarrierCsvRow>> {
    let text = std::fs::read_to_string(path).map_err(|e| ReplayError::io(path, e))?;
    let bad = |line: usize, message: String| ReplayError::CarrierCsv {
        path: path.to_path_buf(),
        line,
        message,
    };
    let mut lines = text.lines();
    if lines.next() != Some(CARRIER_CSV_HEADER) {
        return Err(bad(1, format!("header must be {CARRIER_CSV_HEADER}")));
    }
    lines
        .enumerate()
        .map(|(i, l)| {
            let f: Vec<&str> = l.split(',').collect();
            let num = |k: usize| -> Result<Option<f64>> {
                match f.get(k) {
                    Some(&"") => Ok(None),
                    Some(v) => v
                        .parse()
                        .map(Some)
                        .map_err(|_| bad(i + 2, format!("column {} is not a number: {v}", k + 1))),
                    None => Err(bad(i + 2, format!("{} columns, expected 12", f.len()))),
                }
            };
            let need =
                |k: usize| num(k)?.ok_or_else(|| bad(i + 2, format!("column {} is empty", k + 1)));
            let frame = need(1)?;
            if !(frame >= 0.0 && frame.fract() == 0.0) {
                return Err(bad(
                    i + 2,
                    format!("carrier_frame {frame} is not a frame index"),
                ));
            }
            let redrawn = match need(3)? {
                v if v == 0.0 || v == 1.0 => v == 1.0,
                v => return Err(bad(i + 2, format!("redrawn {v} is not 0 or 1"))),
            };
            Ok(CarrierCsvRow {
                carrier_frame: frame as usize,
                redrawn,
                face_score: need(5)?,
                carrier_n: num(6)?.zip(num(7)?).map(|(x, y)| [x, y]),
            })
        })
        .collect()
}

/// A carrier ready to replay: its geometry, and each eye's appearance.
#[derive(Clone, Debug)]
pub struct Carrier {
    pub path: PathBuf,
    /// As the extractor measured it (blinks, the carrier's own `n`).
    pub track: CarrierTrack,
    /// Lid geometry averaged over neighbouring frames (placement and mask).
    pub geometry: CarrierTrack,
    /// Image-left eye first.
    pub eyes: [EyeAppearance; 2],
    pub usage: CarrierUsage,
    pub times_s: Vec<f64>,
    /// How the extractor reads an iris drawn in this carrier, per axis:
    /// `read = offset + slope x drawn` ([`Carrier::calibrate`]); the
    /// identity until measured.
    pub response: Response,
    /// Per carrier frame, how far the extractor's reading of an iris drawn
    /// at the middle departs from `response` there (`None`: not measured
    /// or not read); subtracted before drawing ([`Carrier::calibrate`]).
    pub offsets: Vec<Option<[f32; 2]>>,
}

/// Format of a cached [`Calibration`]; bump when its meaning changes, or
/// when the drawing changes (the calibration measures the drawing).
pub const CALIBRATION_VERSION: u32 = 5;

/// What [`Carrier::calibrate`] measured, for the cache.
#[derive(Clone, Debug, PartialEq, Serialize, serde::Deserialize)]
pub struct Calibration {
    pub version: u32,
    pub response: Response,
    pub offsets: Vec<Option<[f32; 2]>>,
}

impl Calibration {
    /// Reads a cached calibration; `None` when missing or of another
    /// version.
    pub fn load(path: &Path) -> Result<Option<Calibration>> {
        let c: Option<Calibration> = eyereplay_core::read_json_cache(path, "carrier calibration")?;
        Ok(c.filter(|c| c.version == CALIBRATION_VERSION))
    }

    /// Writes the calibration atomically.
    pub fn save(&self, path: &Path) -> Result<()> {
        Ok(eyereplay_core::write_json(path, self)?)
    }
}

/// The extractor's linear response to a drawn iris position, per axis
/// (`[offset, slope]` for x, then y).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, serde::Deserialize)]
pub struct Response {
    pub x: [f64; 2],
    pub y: [f64; 2],
    /// Probe frames measured (0: not measured).
    pub probes: usize,
}

impl Default for Response {
    fn default() -> Self {
        Response {
            x: [0.0, 1.0],
            y: [0.0, 1.0],
            probes: 0,
        }
    }
}

/// Drawn positions of the calibration probes, per axis: a grid over what
/// conversation and reading ask for.
const PROBE_NX: [f64; 5] = [0.3, 0.4, 0.5, 0.6, 0.7];
const PROBE_NY: [f64; 3] = [0.35, 0.5, 0.65];
/// Carrier frames the probes are drawn into.
const PROBE_FRAMES: usize = 8;
/// Frames per block of one drawing in the offsets' pass.
const OFFSET_BLOCK: usize = 3;
/// Drawn positions are kept inside these bounds, whatever the target: the
/// iris stays in the opening.
const DRAWN_NX: (f64, f64) = (0.12, 0.88);
const DRAWN_NY: (f64, f64) = (0.15, 0.85);

impl Response {
    /// The drawn position whose read-back is `target`.
    pub fn inverse(&self, target: [f64; 2]) -> [f64; 2] {
        [
            ((target[0] - self.x[0]) / self.x[1]).clamp(DRAWN_NX.0, DRAWN_NX.1),
            ((target[1] - self.y[0]) / self.y[1]).clamp(DRAWN_NY.0, DRAWN_NY.1),
        ]
    }
}

/// Least-squares `[offset, slope]` of `read` on `drawn` (`(drawn, read)`
/// pairs; at least 3).
fn fit_line(pairs: &[(f64, f64)]) -> Option<[f64; 2]> {
    let (x, y): (Vec<f64>, Vec<f64>) = pairs.iter().copied().unzip();
    (pairs.len() >= 3)
        .then(|| linear_fit(&x, &y))
        .flatten()
        .map(|(slope, offset)| [offset, slope])
}

impl Carrier {
    /// Checks the carrier (see [`CarrierTrack::check`]) and learns its eyes
    /// from up to [`APPEARANCE_FRAMES`] usable frames.
    pub fn prepare(path: &Path, track: CarrierTrack) -> Result<Carrier> {
        let usage = track.check(path)?;
        let usable: Vec<usize> = (0..track.frames.len())
            .filter(|&i| track.skip(i).is_none())
            .collect();
        let step = (usable.len() as f64 / APPEARANCE_FRAMES as f64).max(1.0);
        let mut want = vec![false; track.frames.len()];
        let mut x = 0.0;
        while (x as usize) < usable.len() {
            want[usable[x as usize]] = true;
            x += step;
        }
        let mut builders = [AppearanceBuilder::default(), AppearanceBuilder::default()];
        let mut dec = Decoder::open(path)?;
        let mut i = 0usize;
        dec.frames(|_, img| {
            if i < want.len() && want[i] {
                let eyes = track.frames[i]
                    .eyes
                    .as_ref()
                    .expect("usable frames have eyes");
                for (b, e) in builders.iter_mut().zip(eyes) {
                    b.add(img, e);
                }
            }
            i += 1;
            Ok(if i >= want.len() {
                ControlFlow::Break(())
            } else {
                ControlFlow::Continue(())
            })
        })?;
        let [l, r] = builders;
        let learn = |b: AppearanceBuilder| {
            b.build().ok_or_else(|| {
                ReplayError::carrier(path, "too little of the eyes' whites shows to learn them")
            })
        };
        let eyes = [learn(l)?, learn(r)?];
        Ok(Carrier {
            path: path.to_path_buf(),
            geometry: track.smoothed(GEOMETRY_SMOOTHING_HALF),
            times_s: track.times_s(),
            track,
            eyes,
            usage,
            response: Response::default(),
            offsets: vec![],
        })
    }

    /// What [`Carrier::calibrate`] measured.
    pub fn calibration(&self) -> Calibration {
        Calibration {
            version: CALIBRATION_VERSION,
            response: self.response,
            offsets: self.offsets.clone(),
        }
    }

    /// Takes a cached calibration (one per carrier frame, else ignored).
    pub fn set_calibration(&mut self, c: Calibration) -> bool {
        if c.offsets.len() != self.track.frames.len() {
            return false;
        }
        self.response = c.response;
        self.offsets = c.offsets;
        true
    }

    /// Measures how the extractor reads an iris drawn in this carrier:
    /// the probes (a grid of drawn positions) in `PROBE_FRAMES` usable
    /// frames, each frame read as a still (detector, mesh, iris), and a
    /// line fitted per axis. The iris model's corners lean towards the
    /// iris it sees, so it reads a drawn excursion smaller than drawn (as
    /// it reads a real eye's); sessions are drawn through the inverse, so
    /// the video reads back as the source did.
    pub fn calibrate(&mut self, models: eyereplay_extract::Models) -> Result<()> {
        let usable: Vec<usize> = (0..self.track.frames.len())
            .filter(|&i| self.track.skip(i).is_none())
            .collect();
        let step = (usable.len() / PROBE_FRAMES).max(1);
        let picks: Vec<usize> = usable
            .iter()
            .step_by(step)
            .take(PROBE_FRAMES)
            .copied()
            .collect();
        let mut frames: Vec<(usize, RgbFrame)> = Vec::new();
        let mut dec = Decoder::open(&self.path)?;
        let mut i = 0usize;
        let last = picks.last().copied().unwrap_or(0);
        dec.frames(|_, img| {
            if picks.contains(&i) {
                frames.push((i, RgbFrame::from_view(img)));
            }
            i += 1;
            Ok(if i > last {
                ControlFlow::Break(())
            } else {
                ControlFlow::Continue(())
            })
        })?;
        let mut tracker = eyereplay_extract::Tracker::new(models, 1);
        let (mut px, mut py) = (Vec::new(), Vec::new());
        for (i, frame) in &frames {
            for nx in PROBE_NX {
                for ny in PROBE_NY {
                    let mut f = frame.clone();
                    if self.redraw_at(&mut f, *i, [nx, ny]).is_err() {
                        continue;
                    }
                    let view = f.view();
                    tracker.reset();
                    let face = tracker.process(&view)?;
                    let row = eyereplay_extract::Row::from_face(0, 0.0, face.as_ref());
                    if let Some((rx, ry)) = row.mean_n() {
                        px.push((nx, rx));
                        py.push((ny, ry));
                    }
                }
            }
        }
        let (Some(x), Some(y)) = (fit_line(&px), fit_line(&py)) else {
            return Err(ReplayError::carrier(
                &self.path,
                "the extractor found no face in the calibration frames",
            ));
        };
        if x[1] < 0.2 {
            return Err(ReplayError::carrier(
                &self.path,
                format!(
                    "the extractor barely follows an iris drawn in this carrier (slope {:.2}); the eyes are too small or too blurred",
                    x[1]
                ),
            ));
        }
        // A vertical slope near zero would blow the inverse up: keep it
        // as drawn then.
        let y = if y[1] < 0.2 { [0.0, 1.0] } else { y };
        self.response = Response {
            x,
            y,
            probes: px.len(),
        };
        self.offsets = self.frame_offsets(&mut tracker)?;
        Ok(())
    }

    /// The whole clip read as a video, the iris drawn at `nx` 0.4 and 0.6
    /// in turn ([`OFFSET_BLOCK`] frames each, `ny` 0.5): the slope of the
    /// reading on the drawing, measured as the read-back reads (tracked,
    /// not stills), replaces the probes' horizontal one, and each frame's
    /// departure from the fitted line is its offset. The read-back's error
    /// is mostly the frame's own (its lids, the head's pose, the light:
    /// the iris model's corners depend on them, and the carrier's own
    /// movements are in them); subtracting it leaves the extractor reading
    /// the trajectory.
    fn frame_offsets(
        &mut self,
        tracker: &mut eyereplay_extract::Tracker,
    ) -> Result<Vec<Option<[f32; 2]>>> {
        tracker.reset();
        let drawn_x = |i: usize| {
            if (i / OFFSET_BLOCK).is_multiple_of(2) {
                0.4
            } else {
                0.6
            }
        };
        let mut read: Vec<Option<[f64; 2]>> = vec![None; self.track.frames.len()];
        let mut dec = Decoder::open(&self.path)?;
        let mut i = 0usize;
        let n = read.len();
        dec.frames(|_, img| {
            if i >= n {
                return Ok(ControlFlow::Break(()));
            }
            let mut f = RgbFrame::from_view(img);
            let drawn = self.redraw_at(&mut f, i, [drawn_x(i), 0.5]).is_ok();
            let view = f.view();
            let face = tracker.process(&view)?;
            if drawn {
                let row = eyereplay_extract::Row::from_face(0, 0.0, face.as_ref());
                read[i] = row.mean_n().map(|(x, y)| [x, y]);
            }
            i += 1;
            Ok(ControlFlow::Continue(()))
        })?;
        // Slope from differences a block apart (opposite drawings): the
        // slow part of the frames' own errors cancels.
        let (mut sxy, mut sxx) = (0.0, 0.0);
        for j in OFFSET_BLOCK..n {
            if let (Some(a), Some(b)) = (read[j], read[j - OFFSET_BLOCK]) {
                let dd = drawn_x(j) - drawn_x(j - OFFSET_BLOCK);
                sxy += (a[0] - b[0]) * dd;
                sxx += dd * dd;
            }
        }
        if sxx > 0.0 && sxy / sxx > 0.2 {
            let b = sxy / sxx;
            let xs: Vec<f64> = (0..n)
                .filter_map(|j| read[j].map(|r| r[0] - b * drawn_x(j)))
                .collect();
            let a = xs.iter().sum::<f64>() / xs.len().max(1) as f64;
            self.response.x = [a, b];
        }
        let r = self.response;
        Ok((0..n)
            .map(|j| {
                read[j].map(|v| {
                    [
                        (v[0] - (r.x[0] + r.x[1] * drawn_x(j))) as f32,
                        (v[1] - (r.y[0] + r.y[1] * 0.5)) as f32,
                    ]
                })
            })
            .collect())
    }

    /// Redraws frame `i` with the iris drawn at `drawn` (no inverse).
    fn redraw_at(
        &self,
        frame: &mut RgbFrame,
        i: usize,
        drawn: [f64; 2],
    ) -> std::result::Result<[[f32; 2]; 2], Skip> {
        if let Some(skip) = self.track.skip(i) {
            return Err(skip);
        }
        let eyes = self.geometry.frames[i]
            .eyes
            .as_ref()
            .expect("frames with no skip have eyes");
        let a = redraw_eye(frame, &eyes[0], &self.eyes[0], drawn);
        let b = redraw_eye(frame, &eyes[1], &self.eyes[1], drawn);
        Ok([a.iris_px, b.iris_px])
    }

    pub fn name(&self) -> String {
        self.path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default()
    }

    /// Output size: the carrier's, cropped to even numbers.
    pub fn size(&self) -> (usize, usize) {
        (self.track.width & !1, self.track.height & !1)
    }

    /// Clip length in seconds (first to last frame time).
    pub fn duration_s(&self) -> f64 {
        self.times_s.last().unwrap_or(&0.0) - self.times_s.first().unwrap_or(&0.0)
    }

    /// Redraws both eyes of carrier frame `i` (already decoded into
    /// `frame`) so that the extractor reads `n` ([`Response::inverse`]);
    /// `None` (frame untouched) with the reason when the frame is not
    /// redrawn.
    pub fn redraw(
        &self,
        frame: &mut RgbFrame,
        i: usize,
        n: [f64; 2],
    ) -> std::result::Result<[[f32; 2]; 2], Skip> {
        let off = self.offsets.get(i).copied().flatten().unwrap_or([0.0; 2]);
        let n = [n[0] - off[0] as f64, n[1] - off[1] as f64];
        self.redraw_at(frame, i, self.response.inverse(n))
    }
}

/// Where a session starts in the clip: anywhere the session fits without
/// turning when the clip is long enough, else anywhere; drawn from `seed`.
pub fn start_frame(times_s: &[f64], frames: usize, fps: f64, seed: u64) -> usize {
    let span = times_s.last().unwrap_or(&0.0) - times_s.first().unwrap_or(&0.0);
    let need = frames as f64 / fps;
    let last_start = if span >= need {
        nearest_frame(times_s, times_s[0] + span - need).min(times_s.len() - 1)
    } else {
        times_s.len().saturating_sub(1)
    };
    (eyereplay_core::splitmix64(seed) % (last_start as u64 + 1)) as usize
}

/// Seeded starts [`usable_start_frame`] tries before it settles.
const START_TRIES: u64 = 16;

/// [`start_frame`], moved off a stretch of the carrier whose eyes cannot
/// be redrawn (a long squint, the head turned away): such a session would
/// show the carrier's own gaze under the class's label. The first try is
/// [`start_frame`]'s own start, kept when at least half the session's
/// frames are redrawn (so a carrier usable throughout starts where it
/// always did); else up to [`START_TRIES`] seeded starts, the first that
/// redraws half, or the one that redraws the most.
pub fn usable_start_frame(carrier: &Carrier, frames: usize, fps: f64, seed: u64) -> usize {
    usable_start(&carrier.times_s, frames, fps, seed, |i| {
        carrier.track.skip(i).is_none()
    })
}

/// [`usable_start_frame`] over the carrier's frame times and which of
/// its frames can be redrawn.
fn usable_start(
    times_s: &[f64],
    frames: usize,
    fps: f64,
    seed: u64,
    usable: impl Fn(usize) -> bool,
) -> usize {
    let redrawn = |start: usize| {
        plan_frames(times_s, start, frames, fps)
            .into_iter()
            .filter(|&i| usable(i))
            .count()
    };
    let first = start_frame(times_s, frames, fps, seed);
    let mut best = (redrawn(first), first);
    for t in 1..START_TRIES {
        if 2 * best.0 >= frames {
            break;
        }
        let s = start_frame(times_s, frames, fps, eyereplay_core::splitmix64(seed ^ t));
        let n = redrawn(s);
        if n > best.0 {
            best = (n, s);
        }
    }
    best.1
}

/// The carrier frame each of `frames` output frames (at `fps`) shows,
/// from `start` on: real time, so the head moves at its real speed; at
/// the clip's end the clip plays backwards, then forwards again (a
/// ping-pong loop: the picture never jumps, motion reverses smoothly).
pub fn plan_frames(times_s: &[f64], start: usize, frames: usize, fps: f64) -> Vec<usize> {
    let t0 = times_s[0];
    let span = times_s[times_s.len() - 1] - t0;
    let offset = times_s[start] - t0;
    (0..frames)
        .map(|k| {
            if span <= 0.0 {
                return start;
            }
            let tau = offset + k as f64 / fps;
            let m = tau.rem_euclid(2.0 * span);
            let pos = if m <= span { m } else { 2.0 * span - m };
            nearest_frame(times_s, t0 + pos)
        })
        .collect()
}

/// What a session used and did.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct ReplayStats {
    pub frames: usize,
    pub start_frame: usize,
    /// Times the ping-pong loop turned.
    pub turns: usize,
    pub redrawn: usize,
    pub skipped_no_face: usize,
    pub skipped_blink: usize,
    pub skipped_small_eyes: usize,
    pub skipped_turned: usize,
}

fn turns(plan: &[usize]) -> usize {
    let dir: Vec<i8> = plan
        .windows(2)
        .map(|w| (w[1] as i64 - w[0] as i64).signum() as i8)
        .filter(|&d| d != 0)
        .collect();
    dir.windows(2).filter(|w| w[0] != w[1]).count()
}

/// Draws every output frame (`f(k, yuv420p)`); the trajectory `targets`
/// are normalized iris positions. Returns per-frame records.
fn draw_session(
    carrier: &Carrier,
    targets: &[[f64; 2]],
    plan: &[usize],
    sink: &mut dyn FnMut(usize, &[u8]) -> Result<()>,
) -> Result<Vec<FrameRecord>> {
    let (w, h) = carrier.size();
    let mut yuv = vec![0u8; w * h * 3 / 2];
    let mut records = Vec::with_capacity(plan.len());
    for_each_planned(&carrier.path, &carrier.times_s, plan, &mut |k, i, frame| {
        let mut f = frame.clone();
        let drawn = carrier.redraw(&mut f, i, targets[k]);
        rgb_to_yuv420(&f.data, w, [0, 0, w, h], &mut yuv, w, h);
        sink(k, &yuv)?;
        records.push(FrameRecord {
            carrier_frame: i,
            drawn,
        });
        Ok(())
    })?;
    Ok(records)
}

struct FrameRecord {
    carrier_frame: usize,
    drawn: std::result::Result<[[f32; 2]; 2], Skip>,
}

/// Renders one session: `targets[k]` (normalized iris position) and
/// `inputs[k]` (the canvas position it came from, for the truth file) per
/// output frame at `fps`, starting at carrier frame `start`. Writes the
/// MP4, the truth CSV and the carrier CSV, each atomically.
#[allow(clippy::too_many_arguments)]
pub fn render_replay_session(
    carrier: &Carrier,
    targets: &[[f64; 2]],
    inputs: &[CanvasPos],
    fps: f64,
    start: usize,
    encoder: &EncoderSettings,
    mp4: &Path,
    truth: &Path,
    carrier_csv: &Path,
) -> Result<ReplayStats> {
    let plan = plan_frames(&carrier.times_s, start, targets.len(), fps);
    let (w, h) = carrier.size();
    let mut enc = Encoder::start(mp4, w, h, fps, encoder)?;
    let records = draw_session(carrier, targets, &plan, &mut |_, yuv| {
        enc.write_frame(yuv)?;
        Ok(())
    })?;
    enc.finish()?;
    let mut stats = ReplayStats {
        frames: records.len(),
        start_frame: start,
        turns: turns(&plan),
        ..Default::default()
    };
    let mut rows = Vec::with_capacity(records.len());
    let mut carrier_rows: Vec<u8> = Vec::new();
    writeln!(carrier_rows, "{CARRIER_CSV_HEADER}").expect("writes to a Vec");
    for (k, r) in records.iter().enumerate() {
        let cf = &carrier.track.frames[r.carrier_frame];
        let blink = cf.blink;
        let geometry = carrier.geometry.frames[r.carrier_frame].eyes.as_ref();
        let eye_truth = |side: usize, iris: [f32; 2]| EyeTruthRow {
            yaw_deg: 0.0,
            pitch_deg: 0.0,
            iris_px: [iris[0] as f64, iris[1] as f64],
            nx: targets[k][0],
            ny: targets[k][1],
            aperture: geometry.map_or(0.0, |e| e[side].aperture()),
        };
        let irises = match r.drawn {
            Ok(p) => {
                stats.redrawn += 1;
                p
            }
            Err(s) => {
                match s {
                    Skip::NoFace => stats.skipped_no_face += 1,
                    Skip::Blink => stats.skipped_blink += 1,
                    Skip::SmallEyes => stats.skipped_small_eyes += 1,
                    Skip::Turned => stats.skipped_turned += 1,
                }
                // The carrier's own iris, where it shows (what the frame
                // shows); the carrier CSV says the frame was not redrawn.
                cf.eyes
                    .as_ref()
                    .map_or([[0.0; 2]; 2], |e| [e[0].iris, e[1].iris])
            }
        };
        rows.push(TruthRow {
            frame: k as u64,
            x_px: inputs[k].x_px,
            y_px: inputs[k].y_px,
            eyes: [eye_truth(0, irises[0]), eye_truth(1, irises[1])],
            lid_closure: if blink { 1.0 } else { 0.0 },
            blink,
        });
        let num = |v: Option<f64>| v.map_or(String::new(), |v| format!("{v:.4}"));
        let px = |v: f32| {
            if r.drawn.is_ok() {
                format!("{v:.2}")
            } else {
                String::new()
            }
        };
        writeln!(
            carrier_rows,
            "{k},{},{:.6},{},{},{:.4},{},{},{},{},{},{}",
            r.carrier_frame,
            cf.time_s,
            u8::from(r.drawn.is_ok()),
            r.drawn.err().map_or("", |s| s.label()),
            cf.face_score,
            num(cf.n.map(|n| n[0])),
            num(cf.n.map(|n| n[1])),
            px(irises[0][0]),
            px(irises[0][1]),
            px(irises[1][0]),
            px(irises[1][1]),
        )
        .expect("writes to a Vec");
    }
    eyereplay_dataset::write_truth_csv(truth, &rows)?;
    eyereplay_core::atomic_write(carrier_csv, &carrier_rows)?;
    Ok(stats)
}

/// The replay mode's speed bench on one carrier: `frames` output frames of
/// `targets` (cycled) at `fps`; draw only (decode + redraw + colour
/// conversion), encode only, and end to end in one run.
pub fn run_replay_bench(
    carrier: &Carrier,
    targets: &[[f64; 2]],
    frames: usize,
    fps: f64,
    encoder: &EncoderSettings,
) -> Result<BenchReport> {
    let targets: Vec<[f64; 2]> = targets.iter().copied().cycle().take(frames).collect();
    let inputs = vec![
        CanvasPos {
            x_px: 0.0,
            y_px: 0.0
        };
        frames
    ];
    let (w, h) = carrier.size();
    let plan = plan_frames(&carrier.times_s, 0, frames, fps);
    time_bench(
        BenchShape {
            frames,
            width: w,
            height: h,
            fps,
        },
        encoder,
        0.0,
        |keep: &mut (dyn FrameSink + Send)| {
            draw_session(carrier, &targets, &plan, &mut |k, yuv| {
                keep.frame(k, yuv)?;
                Ok(())
            })
            .map(|_| ())
        },
        |dir| {
            render_replay_session(
                carrier,
                &targets,
                &inputs,
                fps,
                0,
                encoder,
                &dir.join("s.mp4"),
                &dir.join("s_truth.csv"),
                &dir.join("s_carrier.csv"),
            )
            .map(|_| ())
        },
    )
}

/// PSNR (dB, 8-bit RGB) between an output video and the carrier frames it
/// shows, outside both eyes' regions (each eye's lid contour bounds grown
/// by 3 px), on every `every`-th output frame: how untouched the rest of
/// the picture is, up to encoding. `carrier_frames[k]` is the carrier
/// frame of output frame `k` (the carrier CSV's column).
pub fn psnr_outside_eyes(
    carrier: &Carrier,
    output: &Path,
    carrier_frames: &[usize],
    every: usize,
) -> Result<f64> {
    let every = every.max(1);
    let mut outs: Vec<(usize, RgbFrame)> = Vec::new();
    let mut dec = Decoder::open(output)?;
    let mut k = 0usize;
    dec.frames(|_, img| {
        if k.is_multiple_of(every) && k < carrier_frames.len() {
            outs.push((k, RgbFrame::from_view(img)));
        }
        k += 1;
        Ok(ControlFlow::Continue(()))
    })?;
    let plan: Vec<usize> = outs.iter().map(|(k, _)| carrier_frames[*k]).collect();
    let (mut se, mut n) = (0.0f64, 0u64);
    for_each_planned(&carrier.path, &carrier.times_s, &plan, &mut |j, i, src| {
        let out = &outs[j].1;
        let boxes: Vec<[f32; 4]> = carrier.geometry.frames[i]
            .eyes
            .iter()
            .flat_map(|e| e.iter())
            .map(|e| {
                let xs = e.lid.iter().map(|p| p[0]);
                let ys = e.lid.iter().map(|p| p[1]);
                [
                    xs.clone().fold(f32::MAX, f32::min) - 3.0,
                    ys.clone().fold(f32::MAX, f32::min) - 3.0,
                    xs.fold(f32::MIN, f32::max) + 3.0,
                    ys.fold(f32::MIN, f32::max) + 3.0,
                ]
            })
            .collect();
        let (w, h) = (src.width.min(out.width), src.height.min(out.height));
        for y in 0..h {
            for x in 0..w {
                let (fx, fy) = (x as f32 + 0.5, y as f32 + 0.5);
                if boxes
                    .iter()
                    .any(|b| fx >= b[0] && fx <= b[2] && fy >= b[1] && fy <= b[3])
                {
                    continue;
                }
                let (a, b) = (src.pixel(x, y), out.pixel(x, y));
                for c in 0..3 {
                    let d = a[c] as f64 - b[c] as f64;
                    se += d * d;
                }
                n += 3;
            }
        }
        Ok(())
    })?;
    let mse = se / n.max(1) as f64;
    Ok(if mse > 0.0 {
        10.0 * (255.0f64 * 255.0 / mse).log10()
    } else {
        f64::INFINITY
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 20-s carrier at 25 fps whose frames 150-349 (8 s) cannot be
    /// redrawn: a 4-s session must land where at least half its frames
    /// can be (half the possible starts, so 16 tries miss with odds of
    /// 2^-16), and a carrier usable throughout keeps the plain start.
    #[test]
    fn sessions_start_where_the_carrier_s_eyes_can_be_redrawn() {
        let t: Vec<f64> = (0..500).map(|k| k as f64 / 25.0).collect();
        let usable = |i: usize| !(150..350).contains(&i);
        let mut moved = 0;
        for seed in 0..40 {
            let s = usable_start(&t, 100, 25.0, seed, usable);
            let redrawn = plan_frames(&t, s, 100, 25.0)
                .into_iter()
                .filter(|&i| usable(i))
                .count();
            assert!(redrawn >= 50, "seed {seed}: start {s}, {redrawn} redrawn");
            moved += usize::from(s != start_frame(&t, 100, 25.0, seed));
            assert_eq!(
                usable_start(&t, 100, 25.0, seed, |_| true),
                start_frame(&t, 100, 25.0, seed)
            );
        }
        // About half the plain starts put the session mostly in the
        // unusable 8 s: those were moved.
        assert!(moved >= 10, "{moved} of 40 moved");
        // Nothing usable: the plain start, nothing better to find.
        assert_eq!(
            usable_start(&t, 100, 25.0, 3, |_| false),
            start_frame(&t, 100, 25.0, 3)
        );
    }

    #[test]
    fn plan_plays_in_real_time_and_ping_pongs_at_the_ends() {
        // A 10 fps clip of 5 frames (0.4 s), output at 12.5 fps (0.08 s
        // steps, never halfway between two carrier frames).
        let t = [0.0, 0.1, 0.2, 0.3, 0.4];
        let p = plan_frames(&t, 0, 13, 12.5);
        // Output times 0, .08, ... .40 forwards; .48 is .32 on the way back,
        // .80 is the start again, then forwards.
        assert_eq!(p, vec![0, 1, 2, 2, 3, 4, 3, 2, 2, 1, 0, 1, 2]);
        assert_eq!(turns(&p), 2);
        // Never a jump of more than one carrier frame between outputs.
        assert!(p.windows(2).all(|w| w[0].abs_diff(w[1]) <= 1));
        // Starting later shifts the same timeline.
        assert_eq!(&plan_frames(&t, 2, 3, 10.0)[..], &[2, 3, 4]);
    }

    #[test]
    fn fit_line_gives_offset_and_slope() {
        // read = 1 + 2 drawn, exactly.
        assert_eq!(
            fit_line(&[(0.0, 1.0), (1.0, 3.0), (2.0, 5.0)]),
            Some([1.0, 2.0])
        );
        assert_eq!(fit_line(&[(0.0, 1.0), (1.0, 3.0)]), None);
        assert_eq!(fit_line(&[(1.0, 1.0), (1.0, 3.0), (1.0, 2.0)]), None);
    }

    #[test]
    fn carrier_csv_reads_back_and_refuses_another_file() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("s_carrier.csv");
        std::fs::write(
            &p,
            format!(
                "{CARRIER_CSV_HEADER}\n0,12,0.480000,1,,0.9990,0.5100,0.4400,1.00,2.00,3.00,4.00\n\
1,13,0.520000,0,blink,0.0000,,,,,,\n"
            ),
        )
        .unwrap();
        let rows = read_carrier_csv(&p).unwrap();
        assert_eq!(
            rows,
            vec![
                CarrierCsvRow {
                    carrier_frame: 12,
                    redrawn: true,
                    face_score: 0.999,
                    carrier_n: Some([0.51, 0.44]),
                },
                CarrierCsvRow {
                    carrier_frame: 13,
                    redrawn: false,
                    face_score: 0.0,
                    carrier_n: None,
                },
            ]
        );
        std::fs::write(&p, "frame,x,y\n0,1,2\n").unwrap();
        let e = read_carrier_csv(&p).unwrap_err().to_string();
        assert!(
            e.contains("s_carrier.csv: line 1: header must be frame,carrier_frame"),
            "{e}"
        );
    }

    #[test]
    fn a_session_that_fits_never_turns() {
        let t: Vec<f64> = (0..300).map(|i| i as f64 / 30.0).collect();
        for seed in 0..50 {
            let s = start_frame(&t, 125, 25.0, seed);
            let p = plan_frames(&t, s, 125, 25.0);
            assert_eq!(turns(&p), 0, "seed {seed} start {s}");
            assert!(p.iter().all(|&i| i < 300));
        }
        // Shorter than the session: any start, and it turns.
        let short: Vec<f64> = (0..30).map(|i| i as f64 / 30.0).collect();
        let s = start_frame(&short, 125, 25.0, 7);
        assert!(s < 30);
        assert!(turns(&plan_frames(&short, s, 125, 25.0)) >= 4);
    }
}
