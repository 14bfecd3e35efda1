//! Rendering a whole dataset written by `eyereplay prepare`: every session
//! CSV listed in `labels.csv` gets `<stem>.mp4`, `<stem>_truth.csv` and
//! `<stem>_identity.json` beside it, sessions in parallel.

use crate::encode::{ffprobe_for, probe_video};
use crate::rng::mix64;
use crate::session::{render_session, RenderParams};
use crate::{Calibration, GazeMapping, Identity, RenderError};
use eyereplay_core::{read_session_csv, Canvas, CanvasPos};
use eyereplay_dataset::{
    read_blink_column, read_labels, read_metadata, session_paths_of, SessionIdentity, SessionPaths,
};
use rayon::prelude::*;
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};

/// What the dataset's metadata says about rendering.
#[derive(Clone, Debug, PartialEq)]
pub struct DatasetInfo {
    pub canvas: Canvas,
    pub fps: f64,
    /// `None` when the dataset has per-source calibrations only (the
    /// default mapping is used).
    pub calibration: Option<Calibration>,
}

/// One session to render.
#[derive(Clone, Debug, PartialEq)]
pub struct SessionJob {
    /// The session's files (`paths.file` is the CSV relative to the dataset
    /// folder, as in labels.csv).
    pub paths: SessionPaths,
    /// Seed of this session's identity.
    pub seed: u64,
    /// Position of this session among the sessions of its class, in
    /// labels.csv order (0 for the first).
    pub class_index: usize,
}

impl SessionJob {
    /// Which of `n` shared choices (the full-face mode's photos, the replay
    /// mode's carrier videos) this session takes. Each class's sessions
    /// take them in turn, from a start drawn by the dataset seed that is
    /// the same for every class: within a class the choices' counts differ
    /// by at most one, and two classes of the same size use each choice
    /// equally often, so a classifier trained on the dataset cannot tell
    /// the classes by who is in the video. (Drawn by
    /// each session's seed, the bundled default's 12 sessions used 5 of
    /// its 6 photos, one of them only in reading and two only in
    /// conversation.)
    pub fn balanced_choice(&self, dataset_seed: u64, n: usize) -> usize {
        assert!(n > 0, "balanced_choice among no choices");
        let start = (mix64(dataset_seed ^ 0xBA1A_4CED) % n as u64) as usize;
        (start + self.class_index) % n
    }
}

impl DatasetInfo {
    /// The gaze mapping of this dataset's sessions: its canvas and
    /// calibration, with `template`'s gain and viewing distance.
    pub fn mapping(&self, template: &GazeMapping) -> GazeMapping {
        let mut m = GazeMapping::new(self.canvas);
        if let Some(c) = self.calibration {
            m.calibration = c;
        }
        m.gain = template.gain;
        m.viewing_distance_mm = template.viewing_distance_mm;
        m
    }
}

/// Reads `metadata.json` (canvas, fps, calibration).
pub fn read_dataset_info(dir: &Path) -> Result<DatasetInfo, RenderError> {
    let meta = read_metadata(dir)?.dataset;
    Ok(DatasetInfo {
        canvas: meta.canvas,
        fps: meta.fps,
        calibration: meta.calibration,
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

/// Lists the sessions of `labels.csv`, in its order.
pub fn list_sessions(dir: &Path, dataset_seed: u64) -> Result<Vec<SessionJob>, RenderError> {
    let labels = read_labels(dir)?;
    let mut per_class = std::collections::BTreeMap::new();
    Ok(session_paths_of(dir, &labels)
        .into_iter()
        .zip(&labels)
        .map(|(paths, label)| {
            let k = per_class.entry(label.class).or_insert(0);
            *k += 1;
            SessionJob {
                seed: session_seed(dataset_seed, &paths.file),
                class_index: *k - 1,
                paths,
            }
        })
        .collect())
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
    /// Measures how the extractor reads each session's identity (see
    /// [`crate::ResponseMap`]); its result goes into the session's mapping.
    pub response: Option<ResponseProbe>,
}

/// Measures an identity's [`crate::ResponseMap`] for a session's render
/// parameters (identity, size and mapping set) over the range its
/// trajectory covers; `Ok(None)` when it could not be fitted (the session
/// is then drawn at the geometric target).
#[derive(Clone)]
#[allow(clippy::type_complexity)]
pub struct ResponseProbe {
    measure: std::sync::Arc<
        dyn Fn(&RenderParams, &[CanvasPos]) -> Result<Option<crate::ResponseMap>, String>
            + Send
            + Sync,
    >,
    /// Crops per eye the probe's extractor reads with
    /// (`render.extractor_iris_views`), recorded in each session's
    /// identity file so the read-back reads the same way.
    pub iris_views: usize,
}

impl ResponseProbe {
    #[allow(clippy::type_complexity)]
    pub fn new(
        iris_views: usize,
        measure: std::sync::Arc<
            dyn Fn(&RenderParams, &[CanvasPos]) -> Result<Option<crate::ResponseMap>, String>
                + Send
                + Sync,
        >,
    ) -> ResponseProbe {
        ResponseProbe {
            measure,
            iris_views,
        }
    }

    /// The response map for one session's parameters and trajectory.
    pub fn measure(
        &self,
        params: &RenderParams,
        traj: &[CanvasPos],
    ) -> Result<Option<crate::ResponseMap>, String> {
        (self.measure)(params, traj)
    }
}

impl std::fmt::Debug for ResponseProbe {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "ResponseProbe({} iris views)", self.iris_views)
    }
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

#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct DatasetSummary {
    pub sessions: usize,
    pub rendered: usize,
    pub skipped: usize,
    pub failed: Vec<String>,
    pub frames: usize,
    pub clamped_points: usize,
}

/// True when the session's video exists, has as many frames as its CSV
/// rows, and the ground truth is there.
pub fn is_complete(job: &SessionJob, frames: usize, ffprobe: &Path) -> bool {
    let p = &job.paths;
    p.truth.exists()
        && p.identity_json.exists()
        && probe_video(&p.mp4, ffprobe)
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
    let mapping = info.mapping(&opts.params.mapping);
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
                    let files = &job.paths;
                    for target in files.outputs() {
                        for p in eyereplay_core::stale_temp_files(&target) {
                            std::fs::remove_file(&p).map_err(|e| RenderError::io(&p, e))?;
                        }
                    }
                    let traj = read_session_csv(&files.csv)?;
                    let blinks = read_blink_column(&files.csv)?;
                    if files.mp4.exists() && is_complete(job, traj.len(), &ffprobe) {
                        return Ok(SessionOutcome::Skipped);
                    }
                    let mut params = opts.params.clone();
                    params.identity = Identity::sample(job.seed);
                    params.mapping = mapping;
                    params.fps = info.fps;
                    params.natural_blinks = opts.natural_blinks;
                    if let Some(probe) = &opts.response {
                        params.mapping.extractor_response =
                            probe.measure(&params, &traj).map_err(RenderError::Params)?;
                    }
                    let stats = render_session(
                        &traj,
                        blinks.as_deref(),
                        &params,
                        &files.mp4,
                        &files.truth,
                    )?;
                    SessionIdentity {
                        file: files.file.clone(),
                        seed: job.seed,
                        identity: &params.identity,
                        mapping: &params.mapping,
                        width: params.width,
                        height: params.height,
                        fps: params.fps,
                        eyes: stats.eyes.clone(),
                        extractor_iris_views: opts.response.as_ref().map(|p| p.iris_views),
                    }
                    .write(&files.identity_json)?;
                    frames.fetch_add(stats.frames, Ordering::Relaxed);
                    clamped.fetch_add(stats.clamped_points, Ordering::Relaxed);
                    Ok(SessionOutcome::Rendered {
                        frames: stats.frames,
                        clamped_points: stats.clamped_points,
                    })
                })()
                .unwrap_or_else(|e| SessionOutcome::Failed(format!("{}: {e}", job.paths.file)));
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
