//! `eyereplay generate --profile` and `--dry-run`: where a session's cost
//! goes, stage by stage, in CPU-ms per frame, and what the job will take.
//!
//! The job's trajectories are prepared in a scratch folder and a few of
//! its sessions rendered there and read back as the report reads them.
//! `--profile` renders one session alone, so that the process-wide CPU
//! clocks of [`eyereplay_core::profile`] time its stages one by one;
//! `--dry-run` renders as many sessions together as the job renders at
//! once, so that their wall time includes what they cost each other (two
//! sessions on two cores took 18 % longer than two times one alone
//! projected, each stage of each being multi-threaded), and scales it to
//! the job.

use crate::generate::Job;
use crate::{prepare_dataset, Error, Result};
use eyereplay_core::profile::{measure, start_recording, stop_recording, Lap};
use eyereplay_core::{Progress, Shard};
use serde::Serialize;
use std::path::Path;

/// What [`profile_session`] measured.
#[derive(Clone, Debug, Serialize)]
pub struct SessionProfile {
    /// The sessions rendered (labels.csv's `file`).
    pub sessions_measured: Vec<String>,
    /// Frames of the sessions measured.
    pub frames: usize,
    pub fps: f64,
    /// Frames of the whole job (every session).
    pub job_frames: usize,
    /// Sessions the renderer draws at once (`render.jobs`, at most the
    /// job's sessions).
    pub parallel_sessions: usize,
    /// Cores of this machine.
    pub cores: usize,
    /// Extract (cached) and prepare, for the whole job.
    pub prepare: Lap,
    /// The whole render, its stages and the driver's work around them
    /// (listing, verifying and committing files).
    pub render_total: Lap,
    /// A session rendered alone: its stages, nested ones after the stage
    /// they are in (several rendered together: none, the clocks being the
    /// whole process's).
    pub render: Vec<Lap>,
    /// The report's read-back of the videos, one after another.
    pub report_read_back: Lap,
    /// The report's read-back of a full-face session's head pose (with
    /// `read_back_all`; `None` for other backends).
    pub report_head_read_back: Option<Lap>,
    /// Size of the MP4s.
    pub video_bytes: u64,
}

impl SessionProfile {
    /// Whether several sessions were rendered together, as the job renders
    /// them ([`Measure::AsTheJobRuns`]).
    pub fn rendered_together(&self) -> bool {
        self.sessions_measured.len() > 1
    }

    /// CPU seconds the sessions measured cost: their render and, with
    /// `read_back_all`, the report's read-back of their videos and heads.
    pub fn session_cpu_s(&self, read_back_all: bool) -> f64 {
        let mut total = cost(&self.render_total);
        if read_back_all {
            total += cost(&self.report_read_back);
            total += self.report_head_read_back.as_ref().map_or(0.0, cost);
        }
        total
    }

    /// Projected size of the job's videos, from the profiled session's.
    pub fn projected_video_bytes(&self) -> u64 {
        let per_frame = self.video_bytes as f64 / self.frames.max(1) as f64;
        (per_frame * self.job_frames as f64).ceil() as u64
    }

    /// Projected wall seconds of the whole job on this machine, stage by
    /// stage as `generate` runs them, the report reading `read_back`
    /// sessions back whole (see [`Projection`]).
    pub fn projection(&self, read_back: usize) -> Projection {
        // Sessions of the job, in units of the profiled one.
        let n = self.job_frames as f64 / self.frames.max(1) as f64;
        let cores = self.cores.max(1) as f64;
        let parallel = self.parallel_sessions.max(1) as f64;
        let wall = self.render_total.wall_s;
        // Measured together, as the job runs them, the wall time scales;
        // a session measured alone is bound by the cores when the job
        // renders `parallel` at once, or by its own wall time when that
        // leaves cores idle.
        let render_s = if self.rendered_together() {
            wall * n
        } else {
            (cost(&self.render_total) * n / cores).max(wall * n / parallel)
        };
        let rb = &self.report_read_back;
        // The report reads one session's video (its first 120 s) for the
        // visual section whatever the options; then `read_back` sessions'
        // videos one after another (each read by all cores), then their
        // heads, the sessions in parallel.
        let per_session = self.frames as f64 / self.sessions_measured.len().max(1) as f64;
        let visual_s_of_video = crate::EvaluateOptions::default().visual_seconds;
        let visual_frames = (visual_s_of_video * self.fps).min(per_session);
        // A session no longer than the visual section is read once for both
        // the section and the table (the first session the table reads).
        let visual_s = if read_back > 0 && visual_frames >= per_session {
            0.0
        } else {
            rb.wall_s * visual_frames / self.frames.max(1) as f64
        };
        // `read_back` sessions in units of the measured ones.
        let m = read_back as f64 * per_session / self.frames.max(1) as f64;
        let heads = self
            .report_head_read_back
            .as_ref()
            .map_or(0.0, |h| cost(h).max(h.wall_s) * m / cores);
        let read_back_s = rb.wall_s * m + heads;
        Projection {
            prepare_s: self.prepare.wall_s,
            render_s,
            evaluate_s: visual_s + read_back_s,
        }
    }
}

fn cost(l: &Lap) -> f64 {
    l.cpu_s + l.child_cpu_s
}

/// A job's projected wall time, by `generate`'s stages.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Projection {
    pub prepare_s: f64,
    pub render_s: f64,
    pub evaluate_s: f64,
}

impl Projection {
    pub fn total_s(&self) -> f64 {
        self.prepare_s + self.render_s + self.evaluate_s
    }
}

/// Which sessions [`profile_session`] renders.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Measure<'a> {
    /// One session alone (labels.csv's `file`; `None`: the first), its
    /// stages timed one by one (`generate --profile`).
    Alone(Option<&'a str>),
    /// As many sessions as the job renders at once, together, as the job
    /// runs them (`generate --dry-run`): what they cost together is what
    /// the job's sessions cost, contention for the cores included.
    AsTheJobRuns,
}

/// Renders sessions of `job` as `what` says in a scratch folder (removed
/// afterwards), reads them back as the report does, and times it all.
pub fn profile_session(
    job: &Job,
    what: Measure,
    cache: &Path,
    progress: &dyn Progress,
) -> Result<SessionProfile> {
    // Listed, so that a stop (Ctrl-C) removes it too.
    let scratch = eyereplay_core::inflight::ListedTempDir::new()
        .map_err(|e| Error::io(&std::env::temp_dir(), e))?;
    let out = scratch.path();
    let prepare = measured(PREPARE, || {
        prepare_dataset(&job.config, out, cache, progress)
    })?;
    let meta = eyereplay_dataset::read_metadata(out)?.dataset;
    let all = eyereplay_backends::shard_sessions(out, meta.seed, None)?;
    if all.is_empty() {
        return Err(Error::input(
            &job.config_path,
            "the config makes no session",
        ));
    }
    let at_once = job.settings.sessions_at_once().clamp(1, all.len());
    let shard = match what {
        Measure::Alone(None) => Shard::new(0, all.len())?,
        Measure::Alone(Some(name)) => {
            let index = all
                .iter()
                .position(|s| s.paths.file == name)
                .ok_or_else(|| {
                    Error::input(
                        &job.config_path,
                        format!("no session '{name}' (the first is '{}')", all[0].paths.file),
                    )
                })?;
            Shard::new(index, all.len())?
        }
        // Shard 0 of ceil(N / at_once) holds `at_once` sessions spread
        // over the job (with the default, one of each class).
        Measure::AsTheJobRuns => Shard::new(0, all.len().div_ceil(at_once))?,
    };
    let chosen: Vec<String> = all
        .iter()
        .enumerate()
        .filter(|(i, _)| shard.contains(*i))
        .map(|(_, s)| s.paths.file.clone())
        .collect();
    // Process-wide clocks time the stages only while one session renders.
    let alone = chosen.len() == 1;
    if alone {
        start_recording();
    }
    let rendered = measured(RENDER, || {
        eyereplay_backends::render_sessions(
            out,
            &job.settings,
            job.params.clone(),
            Some(shard),
            cache,
            progress,
        )
    });
    let laps = if alone { stop_recording() } else { vec![] };
    let (summary, render_total) = rendered?;
    let render = parents_first(laps);
    // The report reads the videos back one after another.
    let mut read_back = zero(READ_BACK);
    let mut head_read_back = None;
    let mut video_bytes = 0;
    for file in &chosen {
        let video = out.join(file).with_extension("mp4");
        let frames = eyereplay_core::read_session_csv(&out.join(file))?.len();
        let (_, l) = measured(READ_BACK, || {
            crate::evaluate::read_back_session(out, &video, frames, meta.fps)
        })?;
        add(&mut read_back, &l);
        // A full-face session's head is read back too (with read_back_all).
        let paths = eyereplay_dataset::SessionPaths::beside_video(&video);
        if paths.head_csv().is_file() {
            let (_, l) = measured(HEAD_READ_BACK, || {
                eyereplay_backends::face::head_yaw_read_back(
                    &video,
                    &paths.head_csv(),
                    &paths.identity_json,
                    &eyereplay_extract::default_models_dir(),
                    meta.fps,
                    frames,
                )
            })?;
            add(
                head_read_back.get_or_insert_with(|| zero(HEAD_READ_BACK)),
                &l,
            );
        }
        video_bytes += std::fs::metadata(&video)
            .map_err(|e| Error::io(&video, e))?
            .len();
    }
    Ok(SessionProfile {
        sessions_measured: chosen,
        frames: summary.frames,
        fps: meta.fps,
        job_frames: job.frames(),
        parallel_sessions: at_once,
        cores: std::thread::available_parallelism().map_or(1, |n| n.get()),
        prepare: prepare.1,
        render_total,
        render,
        report_read_back: read_back,
        report_head_read_back: head_read_back,
        video_bytes,
    })
}

const PREPARE: &str = "extract+prepare";
const RENDER: &str = "render";
const READ_BACK: &str = "report read-back";
const HEAD_READ_BACK: &str = "report head read-back";

/// `f` timed as one lap (see [`measure`]), its error passed on.
fn measured<T, E>(
    stage: &str,
    f: impl FnOnce() -> std::result::Result<T, E>,
) -> std::result::Result<(T, Lap), E> {
    let (out, lap) = measure(stage, f);
    out.map(|v| (v, lap))
}

fn zero(stage: &str) -> Lap {
    Lap {
        stage: stage.to_string(),
        depth: 0,
        cpu_s: 0.0,
        child_cpu_s: 0.0,
        wall_s: 0.0,
    }
}

fn add(to: &mut Lap, l: &Lap) {
    to.cpu_s += l.cpu_s;
    to.child_cpu_s += l.child_cpu_s;
    to.wall_s += l.wall_s;
}

/// Laps in the order their outermost stage ran, each followed by the laps
/// nested in it (a lap ends after the laps inside it, so the raw order is
/// inner first).
pub fn parents_first(laps: Vec<Lap>) -> Vec<Lap> {
    // Groups (a lap and everything nested in it, in order) not yet
    // placed in an outer lap.
    let mut pending: Vec<Vec<Lap>> = Vec::new();
    for l in laps {
        // The groups that ended inside this lap are the deeper ones at the
        // end of `pending`.
        let k = pending
            .iter()
            .rposition(|g| g[0].depth <= l.depth)
            .map_or(0, |i| i + 1);
        let inner = pending.split_off(k);
        let mut group = vec![l];
        group.extend(inner.into_iter().flatten());
        pending.push(group);
    }
    pending.into_iter().flatten().collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lap_named(stage: &str, depth: usize) -> Lap {
        Lap {
            stage: stage.into(),
            depth,
            cpu_s: 0.0,
            child_cpu_s: 0.0,
            wall_s: 0.0,
        }
    }

    fn timed(stage: &str, cpu_s: f64, child_cpu_s: f64, wall_s: f64) -> Lap {
        Lap {
            stage: stage.into(),
            depth: 0,
            cpu_s,
            child_cpu_s,
            wall_s,
        }
    }

    #[test]
    fn projection_by_hand() {
        // A 100-frame session of a 1000-frame job (10 sessions) on 2 cores,
        // 2 sessions at once.
        let p = SessionProfile {
            sessions_measured: vec!["reading/reading_0000.csv".into()],
            frames: 100,
            fps: 25.0,
            job_frames: 1000,
            parallel_sessions: 2,
            cores: 2,
            prepare: timed(PREPARE, 0.4, 0.0, 0.5),
            render_total: timed(RENDER, 2.0, 1.0, 2.0),
            render: vec![],
            report_read_back: timed(READ_BACK, 1.0, 0.0, 0.8),
            report_head_read_back: Some(timed(HEAD_READ_BACK, 0.5, 0.0, 0.5)),
            video_bytes: 1234,
        };
        assert_eq!(p.session_cpu_s(false), 3.0);
        assert_eq!(p.session_cpu_s(true), 4.5);
        assert_eq!(p.projected_video_bytes(), 12340);
        // Render: 3 CPU-s x 10 sessions over 2 cores = 15 s (their own wall
        // time, 2 s x 10 / 2 at once = 10 s, is not the bound). The visual
        // section reads one whole session back (0.8 s).
        let q = p.projection(0);
        assert_eq!((q.prepare_s, q.render_s, q.evaluate_s), (0.5, 15.0, 0.8));
        // Reading every session back: 10 x 0.8 s one after another, the
        // heads 10 x 0.5 CPU-s over 2 cores; the visual section's session
        // is the table's first, read once.
        let q = p.projection(10);
        assert!((q.evaluate_s - (8.0 + 2.5)).abs() < 1e-12, "{q:?}");
        assert!((q.total_s() - 26.0).abs() < 1e-12);
        // Two of them read back: 2 x 0.8 s, heads 2 x 0.5 CPU-s over 2 cores.
        let q = p.projection(2);
        assert!((q.evaluate_s - (1.6 + 0.5)).abs() < 1e-12, "{q:?}");
        // Two sessions of 50 frames rendered together as the job runs
        // them, in 2 s: the job is 10 such pairs.
        let p = SessionProfile {
            sessions_measured: vec!["a".into(), "b".into()],
            ..p
        };
        let q = p.projection(0);
        assert_eq!(q.render_s, 20.0);
        // The visual section reads one session (50 of the 100 frames).
        assert!((q.evaluate_s - 0.4).abs() < 1e-12);
    }

    #[test]
    fn nested_laps_follow_their_parent_in_run_order() {
        // As recorded: a (holding a/w, a/x with a/x/v, a/y with a/y/z), then b.
        let raw = vec![
            lap_named("a / w", 1),
            lap_named("a / x / v", 2),
            lap_named("a / x", 1),
            lap_named("a / y / z", 2),
            lap_named("a / y", 1),
            lap_named("a", 0),
            lap_named("b", 0),
        ];
        let names: Vec<String> = parents_first(raw).into_iter().map(|l| l.stage).collect();
        assert_eq!(
            names,
            [
                "a",
                "a / w",
                "a / x",
                "a / x / v",
                "a / y",
                "a / y / z",
                "b"
            ]
        );
    }
}
