//! Running the pipeline over whole videos on all cores.
//!
//! Each video is cut by time into segments of about 15 s, each starting on
//! a keyframe where the file allows, whatever the number of workers (so the
//! rows are the same on any machine); every worker owns one set of ONNX
//! sessions, opens its own decoder, seeks to its segment and tracks from a
//! fresh detection there. Workers pull (video, segment) jobs from one
//! queue, so several videos share the cores too. Memory stays bounded:
//! frames are streamed, only the small per-frame rows are kept.

use crate::anchor::anchor_to_head;
use crate::decode::{Decoder, VideoInfo};
use crate::error::{ExtractError, Result};
use crate::image::{ImageView, Planes, Rotation};
use crate::models::{Device, LandmarkModel, Models};
use crate::output::{flag_blinks, Row, DEFAULT_BLINK_RATIO};
use crate::preview;
use crate::profile::{thread_cpu_s, Stage, StageClock, StageTimes};
use crate::tracker::Tracker;
use std::collections::VecDeque;
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::Instant;

/// Default for [`ExtractOptions::mesh_every`]: the face mesh on every
/// second frame. Measured on franck.mp4 against MediaPipe Python: r_x/r_y
/// 0.933/0.613 (every frame: 0.940/0.621) for 30 % less CPU per frame,
/// which is what lifts throughput past 1.5x MediaPipe's on two cores.
pub const DEFAULT_MESH_EVERY: u32 = 2;

/// A video is cut into segments of about this length, however many
/// workers there are, so that its rows do not depend on the machine: each
/// segment's tracker starts from a fresh detection, and where segments
/// start decides which frames get the face mesh. 15 s gives a 30 s clip
/// two segments (both cores of a small machine busy) and a one-hour video
/// 240, which any number of workers share evenly.
const SEGMENT_S: f64 = 15.0;
/// A boundary moved onto a keyframe leaves segments at least this long.
const MIN_SEGMENT_S: f64 = 4.0;

#[derive(Clone, Debug)]
pub struct ExtractOptions {
    pub models_dir: PathBuf,
    /// Worker threads (one inference thread each); 0 = all cores.
    pub threads: usize,
    pub blink_ratio: f64,
    /// Only the first this many seconds of each video.
    pub max_duration_s: Option<f64>,
    /// Write annotated PNGs to this folder, one every `preview_every_s`.
    pub preview_dir: Option<PathBuf>,
    pub preview_every_s: f64,
    /// Face mesh on one frame in this many (see [`Tracker::new`]).
    pub mesh_every: u32,
    /// Crops each eye is read from, 1..=[`crate::MAX_IRIS_VIEWS`] (see
    /// [`Tracker::set_iris_views`]); 1, the default, is MediaPipe's single
    /// crop. Values outside are clamped.
    pub iris_views: usize,
    /// Measure CPU time per stage ([`Extraction::stage_times`]).
    pub profile: bool,
    /// Where the networks run.
    pub device: Device,
    /// Which networks read the face and eyes ([`Tracker::set_landmarks`]).
    pub landmarks: LandmarkModel,
}

impl Default for ExtractOptions {
    fn default() -> Self {
        ExtractOptions {
            models_dir: crate::models::default_models_dir(),
            threads: 0,
            blink_ratio: DEFAULT_BLINK_RATIO,
            max_duration_s: None,
            preview_dir: None,
            preview_every_s: 5.0,
            mesh_every: DEFAULT_MESH_EVERY,
            iris_views: 1,
            profile: false,
            device: Device::default(),
            landmarks: LandmarkModel::default(),
        }
    }
}

impl ExtractOptions {
    /// Refuses options out of their range, by the name the command line
    /// and the Python package give them: outside it blinks take every
    /// frame or none, a video "has no frames", or a preview is written
    /// for every frame. Every extraction checks this before it starts.
    pub fn validate(&self) -> Result<()> {
        let bad = |m: String| Err(ExtractError::Option(m));
        if !(self.blink_ratio > 0.0 && self.blink_ratio < 1.0) {
            return bad(format!(
                "blink_ratio {}: expected a number between 0 and 1 (exclusive)",
                self.blink_ratio
            ));
        }
        if let Some(s) = self.max_duration_s.filter(|s| !(s.is_finite() && *s > 0.0)) {
            return bad(format!(
                "max_seconds {s}: expected a positive number of seconds"
            ));
        }
        let every = self.preview_every_s;
        if self.preview_dir.is_some() && !(every.is_finite() && every > 0.0) {
            return bad(format!(
                "preview_every {every}: expected a positive number of seconds"
            ));
        }
        if self.mesh_every == 0 {
            return bad("mesh_every 0: expected 1 or more".into());
        }
        if !(1..=crate::MAX_IRIS_VIEWS).contains(&self.iris_views) {
            return bad(format!(
                "iris_views {}: expected 1 to {}",
                self.iris_views,
                crate::MAX_IRIS_VIEWS
            ));
        }
        Ok(())
    }

    pub fn worker_count(&self) -> usize {
        if self.threads > 0 {
            self.threads
        } else {
            std::thread::available_parallelism()
                .map(|n| n.get())
                .unwrap_or(1)
        }
    }
}

/// Progress callbacks (the CLI draws bars with them). Called from workers.
pub trait Progress: Sync {
    /// Video `video` is about to start; `frames` is an estimate if known.
    fn start(&self, _video: usize, _frames: Option<u64>) {}
    /// `n` more frames of video `video` are done.
    fn advance(&self, _video: usize, _n: u64) {}
}

/// No progress output.
pub struct NoProgress;
impl Progress for NoProgress {}

/// What came out of one video.
#[derive(Clone, Debug)]
pub struct Extraction {
    pub path: PathBuf,
    pub info: VideoInfo,
    pub rows: Vec<Row>,
    pub face_frames: usize,
    pub blinks: usize,
    pub detector_runs: u64,
    pub decode_errors: u64,
    pub segments: usize,
    /// CPU time per pipeline stage, summed over workers (zero unless
    /// [`ExtractOptions::profile`]).
    pub stage_times: StageTimes,
    /// True when the networks ran on CUDA.
    pub on_cuda: bool,
    /// Wall time of the whole run this video was part of.
    pub elapsed_s: f64,
    /// What the user should know that did not stop the extraction, one
    /// line each without the file's name: corrupt data skipped, a video
    /// that ends well before the duration its container declares.
    pub warnings: Vec<String>,
}

impl Extraction {
    pub fn detection_rate(&self) -> f64 {
        self.face_frames as f64 / self.rows.len().max(1) as f64
    }
    pub fn valid_frames(&self) -> usize {
        self.rows.iter().filter(|r| r.valid()).count()
    }
}

struct SegmentOut {
    rows: Vec<Row>,
    /// True when the segment's start boundary was provably covered: a frame
    /// at or before the boundary came out of the decoder after the seek.
    start_covered: bool,
    detector_runs: u64,
    decode_errors: u64,
    times: StageTimes,
    on_cuda: bool,
}

#[derive(Clone, Copy)]
struct Job {
    video: usize,
    segment: usize,
    t0: Option<f64>,
    t1: Option<f64>,
    /// Where the decoder seeks to start the segment (at or after `t0`
    /// when `t0` is a keyframe's own time, see [`keyframe_plan`]).
    seek_s: Option<f64>,
}

/// Extracts every video; one result per input, in order. Videos that fail
/// (unreadable, no face, ...) get their error; the others still complete.
pub fn extract_many(
    paths: &[PathBuf],
    opts: &ExtractOptions,
    progress: &dyn Progress,
) -> Vec<Result<Extraction>> {
    let started = Instant::now();
    let workers = opts.worker_count();
    if let Err(e) = opts.validate() {
        return paths
            .iter()
            .map(|_| Err(ExtractError::Option(e.to_string())))
            .collect();
    }
    // Fail fast, and once, when the models are missing.
    let missing = crate::models::missing_files(&opts.models_dir);
    if !missing.is_empty() {
        return paths
            .iter()
            .map(|_| {
                Err(ExtractError::ModelsMissing {
                    dir: opts.models_dir.clone(),
                    missing: missing.join(", "),
                })
            })
            .collect();
    }
    tracing::info!(
        "extracting {} video(s): {} worker(s), {} landmarks, models in {}",
        paths.len(),
        workers,
        opts.landmarks.name(),
        opts.models_dir.display()
    );
    let mut infos: Vec<Option<Result<VideoInfo>>> = paths
        .iter()
        .map(|p| Some(crate::decode::probe(p)))
        .collect();
    let mut jobs = VecDeque::new();
    let mut seg_counts = vec![0usize; paths.len()];
    for (v, info) in infos.iter().enumerate() {
        let Some(Ok(info)) = info else { continue };
        let plan = keyframe_plan(&paths[v], info, plan_segments(info, opts.max_duration_s));
        seg_counts[v] = plan.len();
        tracing::info!(
            "{}: {} {}x{}, {} fps, about {} frames in the file, {} segment(s)",
            paths[v].display(),
            info.codec,
            info.width,
            info.height,
            info.avg_fps.map_or("unknown".into(), |f| format!("{f:.2}")),
            info.frames_estimate.map_or("?".into(), |n| n.to_string()),
            plan.len()
        );
        for (s, (t0, t1, seek_s)) in plan.into_iter().enumerate() {
            tracing::debug!(
                "{}: segment {s}: from {t0:?} s to {t1:?} s, decoding from {seek_s:?} s",
                paths[v].display()
            );
            jobs.push_back(Job {
                video: v,
                segment: s,
                t0,
                t1,
                seek_s,
            });
        }
    }
    for (v, info) in infos.iter().enumerate() {
        if let Some(Ok(info)) = info {
            let frames = info
                .frames_estimate
                .map(|n| match (opts.max_duration_s, info.avg_fps) {
                    (Some(d), Some(fps)) => n.min((d * fps).ceil() as u64),
                    _ => n,
                });
            progress.start(v, frames);
        }
    }
    let outs = run_jobs(paths, jobs, &seg_counts, opts, progress, workers);
    let elapsed_s = started.elapsed().as_secs_f64();

    let mut results = vec![];
    for (v, segs) in outs.into_iter().enumerate() {
        let info = match infos[v].take().expect("probed") {
            Ok(i) => i,
            Err(e) => {
                results.push(Err(e));
                continue;
            }
        };
        let mut segs: Vec<SegmentOut> = match segs.into_iter().collect::<Result<Vec<_>>>() {
            Ok(s) => s,
            Err(e) => {
                results.push(Err(e));
                continue;
            }
        };
        let mut n_segments = segs.len();
        if segs.iter().skip(1).any(|s| !s.start_covered) {
            // The seek may have landed after a boundary (a file with a
            // sparse or wrong index): redo this video in one pass.
            tracing::warn!(
                "{}: seek not exact; extracting in one pass",
                paths[v].display()
            );
            let job = Job {
                video: v,
                segment: 0,
                t0: None,
                t1: end_limit(&info, opts.max_duration_s),
                seek_s: None,
            };
            match Models::load_on(&opts.models_dir, opts.device).and_then(|m| {
                run_segment(
                    &mut new_tracker(m, opts),
                    &mut None,
                    &paths[v],
                    job,
                    opts,
                    progress,
                )
            }) {
                Ok(s) => segs = vec![s],
                Err(e) => {
                    results.push(Err(e));
                    continue;
                }
            }
            n_segments = 1;
        }
        results.push(finish_video(
            &paths[v], info, segs, n_segments, opts, elapsed_s,
        ));
    }
    results
}

fn finish_video(
    path: &Path,
    info: VideoInfo,
    segs: Vec<SegmentOut>,
    segments: usize,
    opts: &ExtractOptions,
    elapsed_s: f64,
) -> Result<Extraction> {
    let detector_runs = segs.iter().map(|s| s.detector_runs).sum();
    let decode_errors = segs.iter().map(|s| s.decode_errors).sum();
    let on_cuda = segs.iter().all(|s| s.on_cuda);
    let mut stage_times = StageTimes::default();
    for s in &segs {
        stage_times.add(&s.times);
    }
    let blinks_t0 = opts.profile.then(thread_cpu_s);
    let mut rows: Vec<Row> = segs.into_iter().flat_map(|s| s.rows).collect();
    if rows.is_empty() {
        return Err(ExtractError::NoFrames {
            path: path.to_path_buf(),
        });
    }
    for (i, r) in rows.iter_mut().enumerate() {
        r.frame = i as u64;
    }
    let face_frames = rows.iter().filter(|r| r.face()).count();
    if face_frames == 0 {
        return Err(ExtractError::NoFace {
            path: path.to_path_buf(),
            frames: rows.len(),
        });
    }
    let blinks = flag_blinks(&mut rows, opts.blink_ratio);
    anchor_to_head(&mut rows);
    if let Some(t0) = blinks_t0 {
        stage_times.charge(Stage::Post, thread_cpu_s() - t0);
    }
    let mut warnings = vec![];
    if decode_errors > 0 {
        warnings.push(format!("{decode_errors} corrupt packets or frames skipped"));
    }
    warnings.extend(ended_early(&info, &rows, opts.max_duration_s));
    let rolled = rows.iter().filter(|r| !r.upright()).count();
    if rolled > 0 {
        warnings.push(format!(
            "{rolled} frames with the face turned past 45 deg in the picture are not valid (nx and ny are measured along the image's axes); is the video's rotation right?"
        ));
    }
    warnings.extend(small_eyes(&rows));
    Ok(Extraction {
        path: path.to_path_buf(),
        warnings,
        info,
        rows,
        face_frames,
        blinks,
        detector_runs,
        decode_errors,
        segments,
        stage_times,
        on_cuda,
        elapsed_s,
    })
}

/// Below this median eye width (corner to corner, in the video's pixels)
/// the rows follow the gaze poorly. The first 60 s of `franck.mp4`
/// (eyes 25.5 px) scaled down and extracted, against MediaPipe's rows of
/// the full-size video: vertical r 0.95 at full size, 0.86 at 12.6 px,
/// 0.60 at 8.3 px, 0.37 at 6.2 px, and horizontal r 0.65 at 4.2 px
/// (docs/EXTRACTION.md, "Small faces").
pub const MIN_EYE_WIDTH_PX: f64 = 10.0;

/// A warning when the valid rows' eyes are a median of under
/// [`MIN_EYE_WIDTH_PX`] wide: rows are still written (MediaPipe reads such
/// faces too), but what they hold is mostly the networks' noise.
fn small_eyes(rows: &[Row]) -> Option<String> {
    let mut widths: Vec<f64> = rows
        .iter()
        .filter(|r| r.valid())
        .filter_map(|r| r.eyes.as_ref())
        .map(|eyes| {
            eyes.iter()
                .map(|e| {
                    (e.corner_right.x - e.corner_left.x).hypot(e.corner_right.y - e.corner_left.y)
                        as f64
                })
                .sum::<f64>()
                / 2.0
        })
        .collect();
    if widths.is_empty() {
        return None;
    }
    widths.sort_by(f64::total_cmp);
    let median_px = widths[widths.len() / 2];
    (median_px < MIN_EYE_WIDTH_PX).then(|| {
        format!(
            "the eyes are {median_px:.1} px wide (median, corner to corner): below {MIN_EYE_WIDTH_PX:.0} px the rows follow the gaze poorly (docs/EXTRACTION.md, \"Small faces\"); a larger or closer face gives usable rows"
        )
    })
}

/// Where `--max-seconds` stops a video (stream clock), if it does.
/// A warning when the decoded frames stop well short of the duration the
/// container declares for the video stream (up to `max_duration_s`): a
/// download or copy cut off, whose missing end would otherwise pass as
/// the whole recording. "Well short": by more than a second and 2 % of
/// the declared span, past what edit lists and rounding move.
fn ended_early(info: &VideoInfo, rows: &[Row], max_duration_s: Option<f64>) -> Option<String> {
    let declared_s = match (info.duration_s, max_duration_s) {
        (Some(d), Some(m)) => d.min(m),
        (Some(d), None) => d,
        (None, _) => return None,
    };
    let (first, last) = (rows.first()?, rows.last()?);
    // The last frame lasts one frame interval.
    let frame_s = info.avg_fps.filter(|f| *f > 0.0).map_or(0.0, |f| 1.0 / f);
    let decoded_s = last.time_s - first.time_s + frame_s;
    (declared_s - decoded_s > (0.02 * declared_s).max(1.0)).then(|| {
        format!(
            "the frames end at {decoded_s:.1} s of the {declared_s:.1} s the file declares \
             (cut off?); the rows stop there"
        )
    })
}

fn end_limit(info: &VideoInfo, max_duration_s: Option<f64>) -> Option<f64> {
    max_duration_s.map(|d| info.start_s + d)
}

/// Time ranges `[t0, t1)` for the segments of one video (None = open end):
/// about [`SEGMENT_S`] each, the same for any number of workers.
fn plan_segments(info: &VideoInfo, max_duration_s: Option<f64>) -> Vec<(Option<f64>, Option<f64>)> {
    let end_limit = end_limit(info, max_duration_s);
    let span = match (info.duration_s, max_duration_s) {
        (Some(d), Some(m)) => Some(d.min(m)),
        (Some(d), None) => Some(d),
        (None, m) => m,
    };
    let n = match span {
        Some(s) if s > 0.0 => ((s / SEGMENT_S).round() as usize).max(1),
        _ => 1,
    };
    if n == 1 {
        return vec![(None, end_limit)];
    }
    let span = span.expect("n > 1 needs a span");
    (0..n)
        .map(|k| {
            let t0 = (k > 0).then(|| info.start_s + span * k as f64 / n as f64);
            let t1 = if k + 1 < n {
                Some(info.start_s + span * (k + 1) as f64 / n as f64)
            } else {
                end_limit
            };
            (t0, t1)
        })
        .collect()
}

/// Moves each inner segment boundary of `plan` back onto the keyframe
/// before it.
///
/// A segment that starts between keyframes makes its decoder start at the
/// keyframe before and throw away every frame up to the boundary: with
/// x264's 10 s between keyframes, a 30 s clip cut in two at 15 s decoded a
/// sixth of its frames twice. Starting each segment on a keyframe's own
/// presentation time decodes every frame once. Returns `(t0, t1, seek_s)`
/// per segment; a boundary stays where it was when the container names no
/// keyframe there, or when moving it would leave a segment shorter than
/// [`MIN_SEGMENT_S`]. The keyframes are the file's own, so the plan still
/// depends on nothing but the file.
fn keyframe_plan(
    path: &Path,
    info: &VideoInfo,
    plan: Vec<(Option<f64>, Option<f64>)>,
) -> Vec<(Option<f64>, Option<f64>, Option<f64>)> {
    if plan.len() < 2 {
        return plan.into_iter().map(|(t0, t1)| (t0, t1, t0)).collect();
    }
    let inner: Vec<f64> = plan.iter().skip(1).filter_map(|s| s.0).collect();
    // One seek and one packet read per boundary, no decoding; any trouble
    // keeps the even split (the segments then seek as before).
    let mut keyframes = vec![None; inner.len()];
    if let Ok(mut dec) = Decoder::open(path) {
        for (b, k) in inner.iter().zip(keyframes.iter_mut()) {
            *k = dec.keyframe_before_s(*b).unwrap_or(None);
        }
    }
    let snapped = snap_boundaries(info.start_s, &inner, &keyframes, MIN_SEGMENT_S);
    let frame_s = 1.0 / info.avg_fps.unwrap_or(25.0);
    (0..plan.len())
        .map(|k| {
            let t0 = (k > 0).then(|| snapped[k - 1].0);
            let t1 = if k + 1 < plan.len() {
                Some(snapped[k].0)
            } else {
                plan[k].1
            };
            // Seek half a frame past a keyframe's own time, so that rounding
            // the target to the demuxer's clock cannot land on the keyframe
            // before; from an even split, seek to the boundary itself.
            let seek_s = (k > 0).then(|| match snapped[k - 1] {
                (b, true) => b + 0.5 * frame_s,
                (b, false) => b,
            });
            (t0, t1, seek_s)
        })
        .collect()
}

/// Each boundary `bounds[k]` moved back to its keyframe `keyframes[k]`
/// when that leaves the segment before it at least `min_s` long (counted
/// from `start` or the previous boundary as moved): `(boundary, true)`
/// when moved, `(boundary, false)` when kept. Moving back only ever
/// lengthens the segment after.
fn snap_boundaries(
    start: f64,
    bounds: &[f64],
    keyframes: &[Option<f64>],
    min_s: f64,
) -> Vec<(f64, bool)> {
    let mut out: Vec<(f64, bool)> = Vec::with_capacity(bounds.len());
    for (&b, &key) in bounds.iter().zip(keyframes) {
        let lo = out.last().map_or(start, |p| p.0) + min_s;
        out.push(match key {
            Some(t) if t >= lo && t <= b => (t, true),
            _ => (b, false),
        });
    }
    out
}

fn new_tracker(models: Models, opts: &ExtractOptions) -> Tracker {
    let mut t = Tracker::new(models, opts.mesh_every);
    t.set_iris_views(opts.iris_views);
    t.set_landmarks(opts.landmarks);
    t.clock = StageClock::new(opts.profile);
    t
}

type SegResults = Vec<Vec<Result<SegmentOut>>>;

fn run_jobs(
    paths: &[PathBuf],
    jobs: VecDeque<Job>,
    seg_counts: &[usize],
    opts: &ExtractOptions,
    progress: &dyn Progress,
    workers: usize,
) -> SegResults {
    let slots: Vec<Vec<Mutex<Option<Result<SegmentOut>>>>> = seg_counts
        .iter()
        .map(|&n| (0..n).map(|_| Mutex::new(None)).collect())
        .collect();
    let workers = workers.min(jobs.len()).max(1);
    let queue = Mutex::new(jobs);
    std::thread::scope(|s| {
        for _ in 0..workers {
            s.spawn(|| {
                let mut tracker: Option<Result<Tracker>> = None;
                // The last video's decoder, kept for its next segment.
                let mut open: Option<(usize, Decoder)> = None;
                loop {
                    let Some(job) = queue.lock().expect("queue lock").pop_front() else {
                        break;
                    };
                    let t = tracker.get_or_insert_with(|| {
                        Models::load_on(&opts.models_dir, opts.device).map(|m| new_tracker(m, opts))
                    });
                    let out = match t {
                        Ok(t) => run_segment(t, &mut open, &paths[job.video], job, opts, progress),
                        // Every segment of this worker fails with the load's
                        // message (ExtractError is not Clone: some variants
                        // hold an io::Error).
                        Err(e) => Err(ExtractError::Runtime(e.to_string())),
                    };
                    *slots[job.video][job.segment].lock().expect("slot lock") = Some(out);
                }
            });
        }
    });
    slots
        .into_iter()
        .map(|v| {
            v.into_iter()
                .map(|m| m.into_inner().expect("slot lock").expect("every job ran"))
                .collect()
        })
        .collect()
}

/// Runs one segment. `open` holds the worker's last decoder and the video
/// it reads: a later segment of the same video seeks in it instead of
/// opening the file again (opening an MP4 parses its whole sample index,
/// about 0.09 CPU-s for a one-hour video, for each of its 240 segments).
fn run_segment(
    tracker: &mut Tracker,
    open: &mut Option<(usize, Decoder)>,
    path: &Path,
    job: Job,
    opts: &ExtractOptions,
    progress: &dyn Progress,
) -> Result<SegmentOut> {
    tracker.reset();
    let runs_before = tracker.detector_runs;
    tracker.clock.times = StageTimes::default();
    // A segment from the start needs a fresh decoder (nothing to seek to).
    let mut dec = match open.take() {
        Some((v, dec)) if v == job.video && job.seek_s.is_some() => dec,
        _ => Decoder::open(path)?,
    };
    let errors_before = dec.errors;
    // Opening the file is set-up; the seek and everything decoded from here
    // on is charged to the stages.
    tracker.clock.start();
    if let Some(seek_s) = job.seek_s {
        dec.seek_s(seek_s)?;
    }
    let frame_dt = 1.0 / dec.info.avg_fps.unwrap_or(25.0);
    let mut rows = vec![];
    let mut start_covered = job.t0.is_none();
    let mut pending = 0u64;
    let mut last_preview: Option<i64> = None;
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().to_string())
        .unwrap_or_default();
    let mut result: Result<()> = Ok(());
    dec.frames(|t, img| {
        tracker.clock.lap(Stage::Decode);
        if let Some(t0) = job.t0 {
            if t < t0 {
                start_covered = true;
                return Ok(ControlFlow::Continue(()));
            }
            if rows.is_empty() && t <= t0 {
                start_covered = true;
            }
        }
        if job.t1.is_some_and(|t1| t >= t1) {
            return Ok(ControlFlow::Break(()));
        }
        let mut preview_file = None;
        if let Some(dir) = &opts.preview_dir {
            let every = opts.preview_every_s.max(1e-3);
            let slot = (t / every).floor() as i64;
            // Only a slot's first frame: a segment that starts mid-slot must
            // not add a second picture for it.
            let first_in_slot = t - slot as f64 * every < 1.5 * frame_dt;
            if last_preview != Some(slot) && (first_in_slot || job.t0.is_none()) {
                last_preview = Some(slot);
                preview_file = Some(dir.join(format!("{stem}_{t:08.3}s.png")));
            }
        }
        let face = if preview_file.is_some() {
            tracker.process_with_mesh(img)?
        } else {
            tracker.process(img)?
        };
        if let Some(file) = preview_file {
            if let Err(e) = preview::write_png(&file, img, face.as_ref()) {
                result = Err(e);
                return Ok(ControlFlow::Break(()));
            }
        }
        rows.push(Row::from_face(0, t, face.as_ref()));
        pending += 1;
        if pending >= 16 {
            progress.advance(job.video, pending);
            pending = 0;
        }
        tracker.clock.lap(Stage::Post);
        Ok(ControlFlow::Continue(()))
    })?;
    result?;
    progress.advance(job.video, pending);
    let decode_errors = dec.errors - errors_before;
    *open = Some((job.video, dec));
    Ok(SegmentOut {
        rows,
        start_covered,
        detector_runs: tracker.detector_runs - runs_before,
        decode_errors,
        times: tracker.clock.times,
        on_cuda: tracker.on_cuda(),
    })
}

/// Extraction from frames already in memory (packed RGB, as OpenCV after
/// a colour conversion, decord or torchvision give them), one after
/// another as a video's frames would be decoded, on one tracker: for
/// callers that have frames and no video file. The rows are the same as
/// [`extract_many`] gives for a video of the same frames and times.
pub struct FrameStream {
    tracker: Tracker,
    rows: Vec<Row>,
    width: usize,
    height: usize,
    blink_ratio: f64,
}

/// What a [`FrameStream`] found.
#[derive(Clone, Debug)]
pub struct FrameExtraction {
    pub rows: Vec<Row>,
    pub face_frames: usize,
    pub blinks: usize,
}

impl FrameStream {
    /// A stream of `width` x `height` frames, read as `opts` says (models,
    /// device, landmark model, iris views, mesh period, blink ratio).
    pub fn new(opts: &ExtractOptions, width: usize, height: usize) -> Result<FrameStream> {
        if width < 2 || height < 2 {
            return Err(ExtractError::Frames(format!(
                "frames of {width}x{height} px: too small to hold a face"
            )));
        }
        opts.validate()?;
        let models = Models::load_on(&opts.models_dir, opts.device)?;
        Ok(FrameStream {
            tracker: new_tracker(models, opts),
            rows: Vec::new(),
            width,
            height,
            blink_ratio: opts.blink_ratio,
        })
    }

    /// Reads the next frame: `rgb` holds `height` rows of `width` RGB
    /// pixels; `time_s` is its presentation time, later than the last.
    pub fn push_rgb(&mut self, rgb: &[u8], time_s: f64) -> Result<()> {
        let want = self.width * self.height * 3;
        if rgb.len() != want {
            return Err(ExtractError::Frames(format!(
                "frame {} has {} bytes, a {}x{} RGB frame has {want}",
                self.rows.len(),
                rgb.len(),
                self.width,
                self.height
            )));
        }
        if !time_s.is_finite() || self.rows.last().is_some_and(|r| time_s <= r.time_s) {
            return Err(ExtractError::Frames(format!(
                "frame {}: time {time_s} s does not follow the previous frame's",
                self.rows.len()
            )));
        }
        let img = ImageView {
            planes: Planes::Rgb24 {
                data: rgb,
                stride: self.width * 3,
            },
            raw_w: self.width,
            raw_h: self.height,
            rotation: Rotation::None,
        };
        self.push_image(&img, time_s)
    }

    /// Reads the next frame as a decoder gives it ([`crate::decode::Decoder::frames`]).
    pub fn push_image(&mut self, img: &ImageView, time_s: f64) -> Result<()> {
        if !time_s.is_finite() || self.rows.last().is_some_and(|r| time_s <= r.time_s) {
            return Err(ExtractError::Frames(format!(
                "frame {}: time {time_s} s does not follow the previous frame's",
                self.rows.len()
            )));
        }
        let face = self.tracker.process(img)?;
        self.rows.push(Row::from_face(
            self.rows.len() as u64,
            time_s,
            face.as_ref(),
        ));
        Ok(())
    }

    /// The rows so far (blinks not yet flagged: [`FrameStream::finish`]
    /// flags them against the whole stream's median aperture).
    pub fn rows(&self) -> &[Row] {
        &self.rows
    }

    /// Frames read so far.
    pub fn frames(&self) -> usize {
        self.rows.len()
    }

    /// The rows, blinks flagged as for a video.
    pub fn finish(self) -> Result<FrameExtraction> {
        let mut rows = self.rows;
        if rows.is_empty() {
            return Err(ExtractError::Frames("no frames given".into()));
        }
        let face_frames = rows.iter().filter(|r| r.face()).count();
        let blinks = flag_blinks(&mut rows, self.blink_ratio);
        anchor_to_head(&mut rows);
        Ok(FrameExtraction {
            rows,
            face_frames,
            blinks,
        })
    }
}

/// Extracts one video and writes its CSV atomically (for callers such as
/// `eyereplay prepare` that take videos as sources). No CSV on error.
pub fn extract_video_to_csv(video: &Path, csv: &Path, opts: &ExtractOptions) -> Result<Extraction> {
    let x = extract_many(&[video.to_path_buf()], opts, &NoProgress)
        .pop()
        .expect("one result per video")?;
    crate::output::save_csv(csv, &x.rows)?;
    Ok(x)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::Pt;
    use crate::output::EyeRow;

    /// A video declared 200 s long at 25 fps whose frames stop at
    /// `frames`: the span they cover is `frames / 25` s (the last frame
    /// lasts 40 ms), against 200 s or `max_s`.
    fn span_warning(frames: usize, declared_s: Option<f64>, max_s: Option<f64>) -> Option<String> {
        let info = VideoInfo {
            width: 360,
            height: 288,
            rotation: Rotation::None,
            start_s: 0.5,
            duration_s: declared_s,
            frames_estimate: None,
            avg_fps: Some(25.0),
            codec: "h264".into(),
        };
        let rows: Vec<Row> = (0..frames)
            .map(|k| Row::from_face(k as u64, 0.5 + k as f64 / 25.0, None))
            .collect();
        ended_early(&info, &rows, max_s)
    }

    /// 100 valid rows whose eyes are `width_px` wide, plus one without a
    /// face and one blink whose eyes are 100 px (left out of the median).
    fn rows_with_eyes(width_px: f32) -> Vec<Row> {
        let row = |w: f32, blink: bool| {
            let eye = EyeRow {
                nx: 0.5,
                ny: 0.4,
                aperture: 0.3,
                iris: Pt { x: 50.0, y: 50.0 },
                corner_left: Pt { x: 40.0, y: 50.0 },
                // Tilted by 3-4-5: w along the corners' line.
                corner_right: Pt {
                    x: 40.0 + 0.8 * w,
                    y: 50.0 + 0.6 * w,
                },
                nx_head: 0.5,
            };
            Row {
                frame: 0,
                time_s: 0.0,
                face_score: 1.0,
                eyes: Some([eye, eye]),
                blink,
                head: Vec::new(),
            }
        };
        let mut rows: Vec<Row> = (0..100).map(|_| row(width_px, false)).collect();
        rows.push(row(100.0, true));
        rows.push(Row::from_face(0, 0.0, None));
        rows
    }

    #[test]
    fn eyes_too_small_to_follow_are_warned_of() {
        let w = small_eyes(&rows_with_eyes(6.0)).expect("6-px eyes are warned of");
        assert!(w.starts_with("the eyes are 6.0 px wide (median"), "{w}");
        assert!(w.contains("below 10 px"), "{w}");
        assert_eq!(small_eyes(&rows_with_eyes(MIN_EYE_WIDTH_PX as f32)), None);
        assert_eq!(small_eyes(&rows_with_eyes(25.0)), None);
        // No valid row: nothing to measure.
        assert_eq!(small_eyes(&[Row::from_face(0, 0.0, None)]), None);
    }

    /// The cut-off check by hand: 2,200 frames cover 88.0 s of a declared
    /// 200; the threshold is the larger of 1 s and 2 % of the declared
    /// span (4 s of 200, 1 s of 30).
    #[test]
    fn a_video_that_stops_short_of_its_declared_length_is_named() {
        let w = span_warning(2200, Some(200.0), None).expect("88 s of 200");
        assert!(w.contains("88.0 s of the 200.0 s"), "{w}");
        // 196.4 s covered: 3.6 s short, under 4 s.
        assert_eq!(span_warning(4910, Some(200.0), None), None);
        // 195.6 s covered: 4.4 s short.
        assert!(span_warning(4890, Some(200.0), None).is_some());
        // --max-seconds 30 asks for 30 s: 750 frames are all of it, 700
        // (28 s) are 2 s short, over the 1 s floor.
        assert_eq!(span_warning(750, Some(200.0), Some(30.0)), None);
        assert!(span_warning(700, Some(200.0), Some(30.0))
            .expect("28 s of 30")
            .contains("28.0 s of the 30.0 s"));
        // No declared duration (a stream): nothing to compare with.
        assert_eq!(span_warning(10, None, Some(30.0)), None);
        assert_eq!(span_warning(0, Some(200.0), None), None);
    }

    /// Options out of range are refused by their name, in one line, and
    /// an extraction with them fails before it opens a model or a video.
    #[test]
    fn options_out_of_range_are_named() {
        assert!(ExtractOptions::default().validate().is_ok());
        // Each case: how it spoils the options, and what the error says.
        type Spoil = fn(&mut ExtractOptions);
        let cases: [(Spoil, &str); 7] = [
            (|o| o.blink_ratio = 5.0, "blink_ratio 5"),
            (|o| o.blink_ratio = f64::NAN, "blink_ratio NaN"),
            (|o| o.max_duration_s = Some(-1.0), "max_seconds -1"),
            (|o| o.max_duration_s = Some(0.0), "max_seconds 0"),
            (
                |o| {
                    o.preview_dir = Some("p".into());
                    o.preview_every_s = 0.0
                },
                "preview_every 0",
            ),
            (|o| o.mesh_every = 0, "mesh_every 0"),
            (|o| o.iris_views = 0, "iris_views 0"),
        ];
        for (set, says) in cases {
            let mut o = ExtractOptions {
                models_dir: "/nonexistent-models".into(),
                ..ExtractOptions::default()
            };
            set(&mut o);
            let e = o.validate().unwrap_err().to_string();
            assert!(e.starts_with(says) && !e.contains('\n'), "{e}");
            // Before the (missing) models are looked for.
            let r = extract_many(&["v.mp4".into()], &o, &NoProgress);
            assert_eq!(r[0].as_ref().unwrap_err().to_string(), e);
        }
    }
    use crate::image::Rotation;

    fn info(start_s: f64, duration_s: Option<f64>) -> VideoInfo {
        VideoInfo {
            width: 640,
            height: 480,
            rotation: Rotation::None,
            start_s,
            duration_s,
            frames_estimate: None,
            avg_fps: Some(25.0),
            codec: "h264".into(),
        }
    }

    #[test]
    fn segments_are_about_15_s_whatever_the_workers() {
        // 200 s from t=1: 13 segments of 15.4 s, open at both outer ends.
        let p = plan_segments(&info(1.0, Some(200.0)), None);
        assert_eq!(p.len(), 13);
        assert_eq!(p[0], (None, Some(1.0 + 200.0 / 13.0)));
        assert_eq!(p[12], (Some(1.0 + 200.0 * 12.0 / 13.0), None));
        // A 30 s clip (the bundled sessions, 29.96 s in some containers):
        // two segments of about 15 s.
        assert_eq!(
            plan_segments(&info(0.0, Some(29.96)), None),
            vec![(None, Some(14.98)), (Some(14.98), None)]
        );
        // Under 22.5 s: one pass.
        assert_eq!(
            plan_segments(&info(0.0, Some(22.0)), None),
            vec![(None, None)]
        );
        // --max-seconds 45 of a long video: three segments, the last
        // stopping at 45 s.
        assert_eq!(
            plan_segments(&info(0.0, Some(3600.0)), Some(45.0)),
            vec![
                (None, Some(15.0)),
                (Some(15.0), Some(30.0)),
                (Some(30.0), Some(45.0))
            ]
        );
        // Unknown duration: one pass.
        assert_eq!(plan_segments(&info(0.0, None), None), vec![(None, None)]);
    }

    #[test]
    fn boundaries_move_back_to_their_keyframe_unless_a_segment_gets_short() {
        // A 30 s clip cut at 15 s, keyframes every 10 s: the seek to 15 s
        // lands on 10.
        assert_eq!(
            snap_boundaries(0.0, &[15.0], &[Some(10.0)], 4.0),
            vec![(10.0, true)]
        );
        // A keyframe 3 s after the start would leave a 3 s segment.
        assert_eq!(
            snap_boundaries(0.0, &[15.0], &[Some(3.0)], 4.0),
            vec![(15.0, false)]
        );
        // No keyframe known, or one after the boundary (not a seek's
        // landing place): the boundary stays.
        assert_eq!(
            snap_boundaries(0.0, &[15.0, 30.0], &[None, Some(31.0)], 4.0),
            vec![(15.0, false), (30.0, false)]
        );
        // Each segment is measured from the previous boundary as moved:
        // 15 -> 12, then 30's keyframe at 14 is 2 s after 12, too close,
        // and 45's at 40 is fine.
        assert_eq!(
            snap_boundaries(
                0.0,
                &[15.0, 30.0, 45.0],
                &[Some(12.0), Some(14.0), Some(40.0)],
                4.0
            ),
            vec![(12.0, true), (30.0, false), (40.0, true)]
        );
    }
}
