//! Rendering a whole dataset written by `eyereplay prepare`: every session
//! CSV listed in `labels.csv` gets `<stem>.mp4`, `<stem>_truth.csv` and
//! `<stem>_identity.json` beside it, sessions in parallel.

use crate::encode::{ffprobe_for, probe_video};
use crate::rng::mix64;
use crate::scene::EyeGeometry;
use crate::session::{render_session, RenderParams};
use crate::{Calibration, GazeMapping, Identity, RenderError};
use eyereplay_core::{read_session_csv, Canvas};
use rayon::prelude::*;
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

/// What the dataset's metadata says about rendering.
#[derive(Clone, Debug, PartialEq)]
pub struct DatasetInfo {
    pub canvas: Canvas,
    pub fps: f64,
    /// `None` when metadata.json has no calibration (the default is used).
    pub calibration: Option<Calibration>,
}

/// One session to render.
#[derive(Clone, Debug, PartialEq)]
pub struct SessionJob {
    /// Path of the CSV relative to the dataset folder, as in labels.csv.
    pub file: String,
    pub csv: PathBuf,
    pub mp4: PathBuf,
    pub truth: PathBuf,
    pub identity_json: PathBuf,
    /// Seed of this session's identity.
    pub seed: u64,
}

fn ds_err(path: &Path, message: impl Into<String>) -> RenderError {
    RenderError::Dataset {
        path: path.into(),
        message: message.into(),
    }
}

/// Reads `metadata.json` (canvas, fps, calibration).
pub fn read_dataset_info(dir: &Path) -> Result<DatasetInfo, RenderError> {
    let path = dir.join("metadata.json");
    let text = std::fs::read_to_string(&path).map_err(|e| RenderError::io(&path, e))?;
    let v: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| ds_err(&path, format!("not JSON: {e}")))?;
    let num = |v: &serde_json::Value, k: &str| v.get(k).and_then(|x| x.as_f64());
    let canvas = match v.get("canvas") {
        Some(c) => Canvas {
            width_px: num(c, "width_px").ok_or_else(|| ds_err(&path, "canvas.width_px missing"))?
                as u32,
            height_px: num(c, "height_px")
                .ok_or_else(|| ds_err(&path, "canvas.height_px missing"))?
                as u32,
        },
        None => Canvas::default(),
    };
    let fps = num(&v, "fps").unwrap_or(25.0);
    let calibration = match v.get("calibration") {
        Some(c) if !c.is_null() => Some(Calibration {
            s_x: num(c, "s_x").ok_or_else(|| ds_err(&path, "calibration.s_x missing"))?,
            s_y: num(c, "s_y").ok_or_else(|| ds_err(&path, "calibration.s_y missing"))?,
            mu_x: num(c, "mu_x").ok_or_else(|| ds_err(&path, "calibration.mu_x missing"))?,
            mu_y: num(c, "mu_y").ok_or_else(|| ds_err(&path, "calibration.mu_y missing"))?,
        }),
        _ => None,
    };
    Ok(DatasetInfo {
        canvas,
        fps,
        calibration,
    })
}

/// Seed of a session's identity: a hash of the dataset seed and the
/// session's file name, so re-rendering one session gives the same face.
/// Kept below 2^53 so JSON readers that parse numbers as doubles keep it
/// exact.
pub fn session_seed(dataset_seed: u64, file: &str) -> u64 {
    let mut h = mix64(dataset_seed ^ 0xD5E7);
    for b in file.bytes() {
        h = mix64(h ^ b as u64);
    }
    h & ((1 << 53) - 1)
}

/// Lists the sessions of `labels.csv` (column `file`).
pub fn list_sessions(dir: &Path, dataset_seed: u64) -> Result<Vec<SessionJob>, RenderError> {
    let path = dir.join("labels.csv");
    let mut rdr = csv::Reader::from_path(&path).map_err(|e| ds_err(&path, e.to_string()))?;
    let headers = rdr
        .headers()
        .map_err(|e| ds_err(&path, e.to_string()))?
        .clone();
    let col = headers
        .iter()
        .position(|h| h.trim() == "file")
        .ok_or_else(|| {
            ds_err(
                &path,
                "missing column 'file' (expected file,label,class,sources)",
            )
        })?;
    let mut jobs = Vec::new();
    for (i, rec) in rdr.records().enumerate() {
        let rec = rec.map_err(|e| ds_err(&path, format!("line {}: {e}", i + 2)))?;
        let file = rec.get(col).unwrap_or("").trim().to_string();
        if file.is_empty() || Path::new(&file).is_absolute() || file.contains("..") {
            return Err(ds_err(&path, format!("line {}: bad file '{file}'", i + 2)));
        }
        let csv = dir.join(&file);
        let stem = csv
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let parent = csv.parent().unwrap_or(dir).to_path_buf();
        jobs.push(SessionJob {
            seed: session_seed(dataset_seed, &file),
            mp4: parent.join(format!("{stem}.mp4")),
            truth: parent.join(format!("{stem}_truth.csv")),
            identity_json: parent.join(format!("{stem}_identity.json")),
            csv,
            file,
        });
    }
    Ok(jobs)
}

#[derive(Clone, Debug)]
pub struct DatasetOptions {
    pub dataset_seed: u64,
    /// Sessions rendered at once.
    pub jobs: usize,
    /// Template for every session; identity and mapping are set per session.
    pub params: RenderParams,
    pub natural_blinks: bool,
    /// `(k, n)`: render only the sessions whose position in labels.csv is
    /// `k` modulo `n` (one shard of a cluster run); `None` renders all.
    pub shard: Option<(usize, usize)>,
}

/// Progress of a dataset render, reported after every session.
#[derive(Clone, Debug)]
pub enum SessionOutcome {
    Rendered {
        frames: usize,
        clamped_points: usize,
    },
    Skipped,
    Failed(String),
}

#[derive(Clone, Debug, Default, Serialize)]
pub struct DatasetSummary {
    pub sessions: usize,
    pub rendered: usize,
    pub skipped: usize,
    pub failed: Vec<String>,
    pub frames: usize,
    pub clamped_points: usize,
}

/// Metadata written beside each video.
#[derive(Serialize)]
struct SessionMeta<'a> {
    file: &'a str,
    seed: u64,
    identity: &'a Identity,
    mapping: &'a GazeMapping,
    width: usize,
    height: usize,
    fps: f64,
    eyes: [EyeGeometry; 2],
}

/// True when the session's video exists, has as many frames as its CSV
/// rows, and the ground truth is there.
pub fn is_complete(job: &SessionJob, frames: usize, ffprobe: &Path) -> bool {
    job.truth.exists()
        && job.identity_json.exists()
        && probe_video(&job.mp4, ffprobe)
            .map(|i| i.frames as usize == frames)
            .unwrap_or(false)
}

pub fn render_dataset(
    dir: &Path,
    opts: &DatasetOptions,
    progress: &(dyn Fn(&SessionJob, &SessionOutcome) + Sync),
) -> Result<DatasetSummary, RenderError> {
    let info = read_dataset_info(dir)?;
    let mut jobs = list_sessions(dir, opts.dataset_seed)?;
    if let Some((k, n)) = opts.shard {
        jobs = jobs
            .into_iter()
            .enumerate()
            .filter(|(i, _)| i % n.max(1) == k)
            .map(|(_, j)| j)
            .collect();
    }
    let mut mapping = GazeMapping::new(info.canvas);
    if let Some(c) = info.calibration {
        mapping.calibration = c;
    }
    mapping.gain = opts.params.mapping.gain;
    mapping.viewing_distance_mm = opts.params.mapping.viewing_distance_mm;
    let ffprobe = ffprobe_for(&opts.params.encoder.ffmpeg);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(opts.jobs.max(1))
        .build()
        .map_err(|e| RenderError::Params(e.to_string()))?;
    let frames = AtomicUsize::new(0);
    let clamped = AtomicUsize::new(0);
    let outcomes: Vec<SessionOutcome> = pool.install(|| {
        jobs.par_iter()
            .map(|job| {
                let outcome = (|| -> Result<SessionOutcome, RenderError> {
                    // Leftovers of an interrupted render of this session (a
                    // killed run's `.NAME.mp4.PID.part`, temp CSV/JSON). Only
                    // this job's files: other shards may be writing theirs.
                    for target in [&job.mp4, &job.truth, &job.identity_json] {
                        for p in eyereplay_core::stale_temp_files(target) {
                            std::fs::remove_file(&p).map_err(|e| RenderError::io(&p, e))?;
                        }
                    }
                    let traj = read_session_csv(&job.csv)?;
                    let blinks = read_blink_column(&job.csv)?;
                    if job.mp4.exists() && is_complete(job, traj.len(), &ffprobe) {
                        return Ok(SessionOutcome::Skipped);
                    }
                    let mut params = opts.params.clone();
                    params.identity = Identity::sample(job.seed);
                    params.mapping = mapping;
                    params.fps = info.fps;
                    params.natural_blinks = opts.natural_blinks;
                    let stats =
                        render_session(&traj, blinks.as_deref(), &params, &job.mp4, &job.truth)?;
                    let meta = SessionMeta {
                        file: &job.file,
                        seed: job.seed,
                        identity: &params.identity,
                        mapping: &params.mapping,
                        width: params.width,
                        height: params.height,
                        fps: params.fps,
                        eyes: stats.eyes.clone().expect("render_session reports geometry"),
                    };
                    let json = serde_json::to_vec_pretty(&meta)
                        .map_err(|e| RenderError::Params(e.to_string()))?;
                    eyereplay_core::atomic_write(&job.identity_json, &json)?;
                    frames.fetch_add(stats.frames, Ordering::Relaxed);
                    clamped.fetch_add(stats.clamped_points, Ordering::Relaxed);
                    Ok(SessionOutcome::Rendered {
                        frames: stats.frames,
                        clamped_points: stats.clamped_points,
                    })
                })()
                .unwrap_or_else(|e| SessionOutcome::Failed(format!("{}: {e}", job.file)));
                progress(job, &outcome);
                outcome
            })
            .collect()
    });
    let mut s = DatasetSummary {
        sessions: jobs.len(),
        frames: frames.into_inner(),
        clamped_points: clamped.into_inner(),
        ..Default::default()
    };
    for o in outcomes {
        match o {
            SessionOutcome::Rendered { .. } => s.rendered += 1,
            SessionOutcome::Skipped => s.skipped += 1,
            SessionOutcome::Failed(m) => s.failed.push(m),
        }
    }
    Ok(s)
}

/// Reads an optional `blink` column (0/1 or true/false) of a session CSV.
pub fn read_blink_column(path: &Path) -> Result<Option<Vec<bool>>, RenderError> {
    let mut rdr = csv::Reader::from_path(path).map_err(|e| ds_err(path, e.to_string()))?;
    let headers = rdr
        .headers()
        .map_err(|e| ds_err(path, e.to_string()))?
        .clone();
    let Some(col) = headers.iter().position(|h| h.trim() == "blink") else {
        return Ok(None);
    };
    let mut out = Vec::new();
    for (i, rec) in rdr.records().enumerate() {
        let rec = rec.map_err(|e| ds_err(path, format!("line {}: {e}", i + 2)))?;
        let v = match rec.get(col).unwrap_or("").trim() {
            "1" | "true" | "True" => true,
            "0" | "false" | "False" | "" => false,
            other => {
                return Err(ds_err(
                    path,
                    format!("line {}: blink must be 0 or 1, got '{other}'", i + 2),
                ))
            }
        };
        out.push(v);
    }
    Ok(Some(out))
}
