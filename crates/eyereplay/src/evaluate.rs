//! Stage 8: a dataset's fidelity, distributional and visual, written as
//! `report/index.html` and `report/metrics.json`.
//!
//! Distributional fidelity is [`eyereplay_eval`]'s. Visual fidelity needs the
//! extractor too, so it is put together here: one rendered video is read
//! back with the extractor and its iris compared frame by frame with the
//! trajectory that drove it.

use crate::{Error, Result};
use eyereplay_core::{read_session_csv, CanvasPos};
use eyereplay_dataset::{
    read_blink_column, read_metadata, read_truth_csv, session_calibrations, SessionIdentity,
    SessionPaths,
};
use eyereplay_eval::{
    compare_visual, evaluate_dataset, write_report, EvalConfig, Evaluation, VisualRun,
    VisualSection,
};
use eyereplay_extract::{extract_at_corners, extract_with_detector, row_norm, widen_blinks};
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// Which video the visual-fidelity section compares.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum VisualChoice {
    /// The first rendered reading session, if any (else the section says why not).
    #[default]
    Auto,
    /// Skip the section.
    Skip,
    /// This session (path relative to the dataset, as in labels.csv).
    Session(String),
    /// Any rendered video and the `frame,x,y` canvas trajectory that drove
    /// it (e.g. another simulator's), mapped back with the dataset's pooled
    /// calibration.
    Video { video: PathBuf, trajectory: PathBuf },
}

/// Options of [`evaluate`]; the defaults are the report's.
#[derive(Clone, Debug)]
pub struct EvaluateOptions {
    pub config: EvalConfig,
    pub visual: VisualChoice,
    /// Compare only the first this many seconds of the video (the paper: 120).
    pub visual_seconds: f64,
    /// Folder of the iris models (default: the extractor's default folder).
    pub models: Option<PathBuf>,
    /// Also read every rendered session back whole and tabulate each one
    /// (costs one extraction of every video).
    pub read_back_all: bool,
    /// Without `read_back_all`: read back whole, and tabulate, the first
    /// this many sessions of each class (0: none; default 1). A sample
    /// that shows each class's fidelity at a fraction of the cost (the
    /// first is the visual section's session, read once for both).
    pub read_back_per_class: usize,
}

impl EvaluateOptions {
    /// The sessions of each class read back whole: every one with
    /// `read_back_all`, else `read_back_per_class`.
    fn sessions_read_back_per_class(&self) -> usize {
        if self.read_back_all {
            usize::MAX
        } else {
            self.read_back_per_class
        }
    }
}

impl Default for EvaluateOptions {
    fn default() -> Self {
        EvaluateOptions {
            config: EvalConfig::default(),
            visual: VisualChoice::Auto,
            visual_seconds: 120.0,
            models: None,
            read_back_all: false,
            read_back_per_class: 1,
        }
    }
}

/// What [`evaluate`] measured and where it wrote it.
pub struct EvaluateOutcome {
    pub evaluation: Evaluation,
    pub html: PathBuf,
    pub metrics_path: PathBuf,
    /// The metrics.json text.
    pub metrics_json: String,
}

/// Measures a dataset's fidelity and writes its report.
pub fn evaluate(dir: &Path, opts: &EvaluateOptions) -> Result<EvaluateOutcome> {
    evaluate_with_progress(dir, opts, &eyereplay_core::NoProgress)
}

/// [`evaluate`], its read-backs of the rendered videos (the visual
/// section's, and one session per class or every one: seconds to minutes)
/// shown as an extraction stage on `progress`.
pub fn evaluate_with_progress(
    dir: &Path,
    opts: &EvaluateOptions,
    progress: &dyn eyereplay_core::Progress,
) -> Result<EvaluateOutcome> {
    check_options(opts)?;
    check_labels(dir)?;
    eyereplay_eval::check_report_place(dir)?;
    let mut ev = evaluate_dataset(dir, &opts.config)?;
    let memo = ReadBackMemo {
        done: Default::default(),
        progress,
    };
    // A bar only where videos are read (not with --no-visual --read-back 0).
    let reads =
        !matches!(opts.visual, VisualChoice::Skip) || opts.sessions_read_back_per_class() > 0;
    if reads {
        // The whole stage's frames up front: a total that grew as each
        // video opened showed a bar near its end at every video.
        let total = planned_read_back_frames(dir, opts, &ev);
        progress.begin(eyereplay_core::Stage::Extract, total);
        progress.status("(reading the videos back)");
    }
    let read = evaluate_read_backs(dir, opts, &mut ev, &memo);
    if reads {
        progress.end(eyereplay_core::Stage::Extract);
    }
    read?;
    let (paths, metrics_json) = write_report(dir, &ev)?;
    Ok(EvaluateOutcome {
        evaluation: ev,
        html: paths.html,
        metrics_path: paths.metrics,
        metrics_json,
    })
}

/// The frames [`evaluate_read_backs`] will read, chosen as it chooses
/// them (the visual section's session, then each class's first sessions
/// with a video) and counted once per video and frame count, as
/// [`ReadBackMemo`] reads them. A dataset session has `ev.session_frames`
/// (its loader checked every CSV); a session that cannot be read is left
/// to the read-back itself to report.
fn planned_read_back_frames(dir: &Path, opts: &EvaluateOptions, ev: &Evaluation) -> u64 {
    let visual_n = |len: usize| ((opts.visual_seconds * ev.fps).round() as usize).min(len);
    let mut reads: Vec<(PathBuf, usize)> = vec![];
    match &opts.visual {
        VisualChoice::Skip => {}
        // Another renderer's video: its own trajectory's length.
        VisualChoice::Video { video, trajectory } => {
            if let Ok(rows) = read_session_csv(trajectory) {
                reads.push((video.clone(), visual_n(rows.len())));
            }
        }
        choice => {
            if let Ok(Ok(t)) = visual_target(dir, choice, ev) {
                reads.push((t.video, visual_n(ev.session_frames)));
            }
        }
    }
    for class in &ev.classes {
        let sessions = class
            .events
            .iter()
            .filter_map(|(file, _)| SessionPaths::new(dir, file).ok())
            .filter(|p| p.mp4.is_file())
            .map(|p| (p.mp4, ev.session_frames));
        reads.extend(sessions.take(opts.sessions_read_back_per_class()));
    }
    reads.sort();
    reads.dedup();
    reads.iter().map(|(_, n)| *n as u64).sum()
}

/// The visual section and the table of sessions read back.
fn evaluate_read_backs(
    dir: &Path,
    opts: &EvaluateOptions,
    ev: &mut Evaluation,
    memo: &ReadBackMemo,
) -> Result<()> {
    ev.visual = match &opts.visual {
        VisualChoice::Skip => VisualSection::NotComputed {
            reason: "not computed: skipped (--no-visual, or visual=False in Python)".into(),
        },
        choice => visual_section(dir, choice, opts, ev, memo)?,
    };
    let per_class = opts.sessions_read_back_per_class();
    if per_class > 0 {
        ev.sessions_read_back = sessions_read_back(dir, opts, ev, per_class, memo)?;
    }
    Ok(())
}

/// `labels.csv` lists the sessions `metadata.json` plans
/// ([`crate::check_labels_against_plan`]): a row repeated was evaluated
/// twice, with other KS figures and no word.
fn check_labels(dir: &Path) -> Result<()> {
    let meta = eyereplay_dataset::read_metadata(dir)?;
    if meta.dataset.sessions.is_empty() {
        return Ok(()); // nothing planned to compare with
    }
    let jobs = eyereplay_render::list_sessions(dir, meta.dataset.seed)?;
    let listed: Vec<(&str, eyereplay_core::GazeClass)> = jobs
        .iter()
        .map(|j| (j.paths.file.as_str(), j.class))
        .collect();
    crate::check_labels_against_plan(dir, &meta.dataset, &listed)
}

fn check_options(o: &EvaluateOptions) -> Result<()> {
    let t = &o.config.thresholds;
    let bad = |m: String| Err(Error::Setting(m));
    // Finite too: an infinite saccade threshold found no saccade at all and
    // was written to metrics.json as null.
    if !(t.fixation_below_px_per_frame > 0.0
        && t.saccade_above_px_per_frame >= t.fixation_below_px_per_frame
        && t.saccade_above_px_per_frame.is_finite())
    {
        return bad(format!(
            "thresholds: need 0 < --fixation-below <= --saccade-above, both finite (got {} and {})",
            t.fixation_below_px_per_frame, t.saccade_above_px_per_frame
        ));
    }
    if o.config.window_s.is_nan() || o.config.window_s <= 0.0 {
        return bad("--window-s must be positive".into());
    }
    if o.visual_seconds.is_nan() || o.visual_seconds <= 0.0 {
        return bad(
            "the visual section's seconds (--visual-seconds, visual_seconds=) must be positive"
                .into(),
        );
    }
    Ok(())
}

/// The video to compare, its driving trajectory, and the dataset session it
/// belongs to (if any).
struct VisualTarget {
    video: PathBuf,
    trajectory: PathBuf,
    truth: Option<PathBuf>,
    session: Option<String>,
}

/// Picks the video and trajectory to compare. An explicit choice must
/// work; the automatic one returns why it could not run.
fn visual_target(
    dir: &Path,
    choice: &VisualChoice,
    ev: &Evaluation,
) -> Result<std::result::Result<VisualTarget, NotComputed>> {
    let session = match choice {
        VisualChoice::Video { video, trajectory } => {
            if !video.is_file() {
                return Err(Error::input(video, "not found"));
            }
            return Ok(Ok(VisualTarget {
                video: video.clone(),
                trajectory: trajectory.clone(),
                truth: None,
                session: None,
            }));
        }
        VisualChoice::Session(s) => s.clone(),
        VisualChoice::Auto | VisualChoice::Skip => {
            let first = ev
                .classes
                .iter()
                .flat_map(|c| c.events.iter().map(|(f, _)| f.clone()))
                .find(|f| SessionPaths::new(dir, f).is_ok_and(|p| p.mp4.is_file()));
            match first {
                Some(f) => f,
                None => {
                    return Ok(Err(NotComputed(
                        "not computed: no rendered session found (a video <class>/<stem>.mp4 \
beside a session CSV); run 'eyereplay render' first, or pass --video and --trajectory"
                            .into(),
                    )))
                }
            }
        }
    };
    let paths = SessionPaths::new(dir, &session)?;
    if !paths.mp4.is_file() {
        return Err(Error::input(
            &paths.mp4,
            format!("not found (the rendered video of {session})"),
        ));
    }
    Ok(Ok(VisualTarget {
        // The renderer's truth: a browser page's own columns are not
        // the drawn eyes' (the sections that need them are left out).
        truth: eyereplay_dataset::has_renderer_truth(&paths.truth).then(|| paths.truth.clone()),
        video: paths.mp4,
        trajectory: paths.csv,
        session: Some(session),
    }))
}

/// Canvas px back to normalized iris units, with the calibration that
/// produced each frame (pooled, or per source for a dataset session).
fn source_norm(dir: &Path, target: &VisualTarget, input: &[CanvasPos]) -> Result<Vec<[f64; 2]>> {
    let meta = read_metadata(dir)?.dataset;
    let cals = match &target.session {
        Some(rel) => session_calibrations(dir, &meta, rel, input.len())?,
        None => vec![
            meta.calibration.ok_or_else(|| Error::input(
                dir.join(eyereplay_dataset::layout::METADATA_FILE),
                "--trajectory needs the dataset's pooled calibration; \
for per-source calibrations compare a dataset session (--visual-session)",
            ))?;
            input.len()
        ],
    };
    Ok(input
        .iter()
        .zip(&cals)
        .map(|(c, cal)| {
            let n = cal.canvas_to_norm(*c);
            [n.nx, n.ny]
        })
        .collect())
}

/// Frames where the eyes are closed (the session's or the render's blink
/// column, widened by two frames each side, since lids are part-closed just
/// before and after a flagged blink) or not drawn (a replay carrier's
/// frames left as they are): they carry no iris position of the session.
fn closed_frames(target: &VisualTarget, frames: usize) -> Result<Vec<bool>> {
    let mut closed = vec![false; frames];
    let files = std::iter::once(&target.trajectory).chain(target.truth.as_ref());
    for p in files {
        if let Some(b) = read_blink_column(p)? {
            for (c, b) in closed.iter_mut().zip(b) {
                *c |= b;
            }
        }
    }
    // The replay mode's frames left as the carrier shows them (a blink,
    // no face, eyes too small, a head turned too far) carry the carrier's
    // eyes, not the session's.
    let carrier_csv = SessionPaths::beside_video(&target.video).carrier_csv();
    if carrier_csv.is_file() {
        for (c, row) in closed.iter_mut().zip(
            eyereplay_backends::replay::read_carrier_csv(&carrier_csv)
                .map_err(eyereplay_backends::BackendError::from)?,
        ) {
            *c |= !row.redrawn;
        }
    }
    Ok(widen_blinks(&closed))
}

fn masked(n: &[[f64; 2]], closed: &[bool]) -> Vec<[f64; 2]> {
    n.iter()
        .zip(closed)
        .map(|(r, &c)| if c { [f64::NAN, f64::NAN] } else { *r })
        .collect()
}

fn visual_section(
    dir: &Path,
    choice: &VisualChoice,
    opts: &EvaluateOptions,
    ev: &mut Evaluation,
    memo: &ReadBackMemo,
) -> Result<VisualSection> {
    let explicit = !matches!(choice, VisualChoice::Auto);
    let not_computed = |reason: String| -> Result<VisualSection> {
        if explicit {
            Err(Error::Setting(reason))
        } else {
            Ok(VisualSection::NotComputed { reason })
        }
    };
    let target = match visual_target(dir, choice, ev)? {
        Ok(t) => t,
        Err(NotComputed(reason)) => return Ok(VisualSection::NotComputed { reason }),
    };
    let models = opts
        .models
        .clone()
        .unwrap_or_else(eyereplay_extract::default_models_dir);
    let missing = eyereplay_extract::missing_files(&models);
    if !missing.is_empty() {
        return not_computed(format!(
            "not computed: iris models missing in {} ({}); run scripts/setup.sh (or `cargo xtask models`)",
            models.display(),
            missing.join(", ")
        ));
    }
    let input: Vec<CanvasPos> = read_session_csv(&target.trajectory)?;
    check_frame_count(&target.video, input.len())?;
    let source_all = source_norm(dir, &target, &input)?;
    let closed = closed_frames(&target, input.len())?;
    let n = ((opts.visual_seconds * ev.fps).round() as usize).min(input.len());
    if let Some(p) = &target.truth {
        ev.render_truth = Some(render_truth(dir, p, &source_all, &closed, n)?);
    }
    let geometry = SessionPaths::beside_video(&target.video).identity_json;
    let (rendered_n, locator) =
        match memo.read_back(dir, &target.video, &models, n, ev.fps, &geometry)? {
            Ok(r) => (r.n, r.how),
            Err(NotComputed(reason)) => return not_computed(reason),
        };
    let n = n.min(rendered_n.len());
    if n < 2 {
        return Err(Error::input(
            &target.video,
            format!("only {n} frame(s) decoded"),
        ));
    }
    let rendered_n = masked(&rendered_n[..n], &closed);
    let source_n = source_all[..n].to_vec();
    let fidelity = compare_visual(&source_n, &rendered_n, Some((&input[..n], ev.canvas)))
        .map_err(|e| Error::input(&target.video, format!("visual comparison: {e}")))?;
    Ok(VisualSection::Computed(Box::new(VisualRun {
        fidelity,
        detection_rate: detection_rate(&rendered_n),
        source_n,
        rendered_n,
        video: shown(dir, &target.video),
        eye_locator: locator,
    })))
}

/// Every rendered session read back whole (as the visual section reads
/// its one session) and compared with its source, in the report's class
/// order.
fn sessions_read_back(
    dir: &Path,
    opts: &EvaluateOptions,
    ev: &Evaluation,
    per_class: usize,
    memo: &ReadBackMemo,
) -> Result<Vec<eyereplay_eval::SessionReadBack>> {
    let models = opts
        .models
        .clone()
        .unwrap_or_else(eyereplay_extract::default_models_dir);
    eyereplay_extract::check_models(&models)?;
    let mut out = vec![];
    // (row in `out`, video, frames) of each full-face session.
    let mut heads: Vec<(usize, PathBuf, usize)> = vec![];
    for class in &ev.classes {
        let mut taken = 0;
        for (file, _) in &class.events {
            if taken == per_class {
                break;
            }
            let target = match visual_target(dir, &VisualChoice::Session(file.clone()), ev) {
                Ok(Ok(t)) => t,
                // A session without its video (a shard not rendered yet).
                _ => continue,
            };
            let input: Vec<CanvasPos> = read_session_csv(&target.trajectory)?;
            check_frame_count(&target.video, input.len())?;
            let source = source_norm(dir, &target, &input)?;
            let closed = closed_frames(&target, input.len())?;
            let geometry = SessionPaths::beside_video(&target.video).identity_json;
            let back = match memo.read_back(
                dir,
                &target.video,
                &models,
                input.len(),
                ev.fps,
                &geometry,
            )? {
                Ok(r) => r,
                // A video the extractor cannot read (a browser page
                // without a face, and no eye corners configured) has no
                // row here; the visual section says why. It failed the
                // whole evaluation, the documented browser default's
                // among them. The class's other sessions come from the
                // same page: not tried.
                Err(NotComputed(_)) => break,
            };
            taken += 1;
            let n = back.n.len().min(input.len());
            let read = masked(&back.n[..n], &closed[..n]);
            let fidelity = compare_visual(&source[..n], &read, None)
                .map_err(|e| Error::input(&target.video, format!("visual comparison: {e}")))?;
            // A full-face session also has its drawn head to compare (read
            // below, all sessions at once).
            if SessionPaths::beside_video(&target.video)
                .head_csv()
                .is_file()
            {
                heads.push((out.len(), target.video.clone(), input.len()));
            }
            let budget = match (&back.rows, &target.truth) {
                (Some(rows), Some(truth)) => {
                    read_back_budget(truth, input.len(), &rows[..n], &source[..n], &read)?
                }
                _ => None,
            };
            out.push(eyereplay_eval::SessionReadBack {
                session: file.clone(),
                class: class.class.to_string(),
                detection_rate: detection_rate(&read),
                fidelity,
                head_yaw: None,
                budget,
            });
        }
    }
    // The head read-back decodes each video once more on one thread: the
    // sessions in parallel keep every core busy (each result depends on its
    // own video only, so the order of work does not change it).
    let yaws: Vec<Result<eyereplay_eval::HeadYawReadBack>> = heads
        .par_iter()
        .map(|(_, video, frames)| {
            let paths = SessionPaths::beside_video(video);
            eyereplay_backends::face::head_yaw_read_back(
                video,
                &paths.head_csv(),
                &paths.identity_json,
                &models,
                ev.fps,
                *frames,
            )
            .map_err(Error::from)
        })
        .collect();
    for ((k, ..), yaw) in heads.iter().zip(yaws) {
        out[*k].head_yaw = Some(yaw?);
    }
    Ok(out)
}

/// The movement against the extractor's error over the compared frames
/// (`read` finite: an iris read with the eyes open), from the extractor's
/// `rows` and the drawn iris centres of the session's `truth` CSV, which
/// must have the session's `frames`.
fn read_back_budget(
    truth: &Path,
    frames: usize,
    rows: &[eyereplay_extract::Row],
    source: &[[f64; 2]],
    read: &[[f64; 2]],
) -> Result<Option<eyereplay_eval::ReadBackBudget>> {
    let drawn = read_truth_rows(truth, frames)?;
    let px = |p: eyereplay_extract::Pt| [p.x as f64, p.y as f64];
    let (mut src, mut eyes) = (vec![], vec![]);
    for (i, ((row, r), t)) in rows.iter().zip(read).zip(&drawn).enumerate() {
        let Some(e) = &row.eyes else {
            continue;
        };
        if !(r[0].is_finite() && r[1].is_finite()) {
            continue;
        }
        let eye = |k: usize| eyereplay_eval::EyeReadBack {
            iris_px: px(e[k].iris),
            corner_left_px: px(e[k].corner_left),
            corner_right_px: px(e[k].corner_right),
            aperture: e[k].aperture,
            n: [e[k].nx, e[k].ny],
            drawn_iris_px: t.eyes[k].iris_px,
        };
        src.push(source[i]);
        eyes.push([eye(0), eye(1)]);
    }
    Ok(eyereplay_eval::read_back_budget(&src, &eyes))
}

/// A session's truth CSV, refused in one line naming it unless it has the
/// session's `frames`.
fn read_truth_rows(truth: &Path, frames: usize) -> Result<Vec<eyereplay_dataset::TruthRow>> {
    let rows = read_truth_csv(truth)?;
    if rows.len() != frames {
        return Err(Error::input(
            truth,
            format!("{} frames, but its trajectory has {frames}", rows.len()),
        ));
    }
    Ok(rows)
}

/// The renderer's own iris positions against the source: the simulator's
/// mapping without the extractor.
fn render_truth(
    dir: &Path,
    truth: &Path,
    source: &[[f64; 2]],
    closed: &[bool],
    n: usize,
) -> Result<(String, eyereplay_eval::VisualFidelity)> {
    let rows = read_truth_rows(truth, source.len())?;
    let t: Vec<[f64; 2]> = rows[..n].iter().map(|r| r.mean_norm()).collect();
    let cmp = compare_visual(&source[..n], &masked(&t, closed), None)
        .map_err(|e| Error::input(truth, format!("comparing with the source: {e}")))?;
    Ok((shown(dir, truth), cmp))
}

/// Reads the rendered video of one session back as the report does (the
/// extractor, with the crops per eye the session was matched to), the
/// whole video; returns how many frames had open eyes. What the report
/// costs per session (`eyereplay generate --profile`).
pub fn read_back_session(dir: &Path, video: &Path, frames: usize, fps: f64) -> Result<usize> {
    let models = eyereplay_extract::default_models_dir();
    eyereplay_extract::check_models(&models)?;
    check_frame_count(video, frames)?;
    let geometry = SessionPaths::beside_video(video).identity_json;
    match read_back(
        dir,
        video,
        &models,
        frames,
        fps,
        &geometry,
        &eyereplay_extract::NoProgress,
    )? {
        Ok(r) => Ok(r.n.iter().filter(|p| p[0].is_finite()).count()),
        Err(NotComputed(reason)) => Err(Error::input(video, reason)),
    }
}

/// The iris read back from the video: the extractor's own pipeline (face
/// detector -> mesh -> iris); for a close-up whose face the detector does
/// not see, the iris model on eye crops placed at the render's known eye
/// corners. `Err(reason)` when neither can run.
fn read_back(
    dir: &Path,
    video: &Path,
    models: &Path,
    n: usize,
    fps: f64,
    geometry: &Path,
    progress: &dyn eyereplay_extract::Progress,
) -> Result<std::result::Result<ReadBack, NotComputed>> {
    // When the render says where it drew the eyes (a close-up, a browser
    // page), a 4-s trial decides first whether the detector sees a face at
    // all, so a close-up does not cost a full detector pass. A face or a
    // replay session has no such fallback (its head moves), and the trial
    // would only read its first 4 s twice.
    let trial = (4.0 * fps).round() as usize;
    let identity = if geometry.is_file() {
        Some(SessionIdentity::read(geometry)?)
    } else {
        None
    };
    // The crops per eye the session was matched to (absent: one).
    let views = match identity.as_ref().and_then(|i| i.extractor_iris_views) {
        None => 1,
        Some(v) if (1..=eyereplay_extract::MAX_IRIS_VIEWS).contains(&v) => v,
        Some(v) => {
            return Err(Error::input(
                geometry,
                format!(
                    "extractor_iris_views {v} must be from 1 to {}",
                    eyereplay_extract::MAX_IRIS_VIEWS
                ),
            ))
        }
    };
    let views_note = if views > 1 {
        format!(", each eye read from {views} crops")
    } else {
        String::new()
    };
    let has_fallback = identity
        .as_ref()
        .is_some_and(|i| i.corner_pairs_px().is_some());
    let detected = if has_fallback && n > trial {
        match extract_with_detector(video, models, trial, fps, views, progress) {
            Ok(r) if rows_detection_rate(&r) < 0.5 => Ok(r),
            _ => extract_with_detector(video, models, n, fps, views, progress),
        }
    } else {
        extract_with_detector(video, models, n, fps, views, progress)
    };
    match detected {
        Ok(r) if rows_detection_rate(&r) >= 0.5 || identity.is_none() => Ok(Ok(ReadBack {
            n: r.iter().map(row_norm).collect(),
            how: format!("face detector, face mesh and iris model (eyereplay-extract){views_note}"),
            rows: Some(r),
        })),
        first => {
            let Some(identity) = identity else {
                let e = first.expect_err("handled above");
                return Ok(Err(NotComputed(format!(
                    "not computed: {e}; no render geometry ({}) to place the eye crops",
                    shown(dir, geometry)
                ))));
            };
            let Some(corners) = identity.corner_pairs_px() else {
                return Ok(Err(NotComputed(format!(
                    "not computed: the face detector found no face, and {} does not say where the eyes are \
(for a browser page set render.browser_eye_corners_px)",
                    shown(dir, geometry)
                ))));
            };
            let r = extract_at_corners(video, models, corners, n, views)?;
            let seen = match &first {
                Ok(r) => format!("{:.0} %", 100.0 * rows_detection_rate(r)),
                Err(_) => "none".to_string(),
            };
            Ok(Ok(ReadBack {
                n: r,
                how: format!(
                    "iris model on eye crops placed from the render's known geometry ({}; \
nx against its fixed eye corners, ny against the model's lids{views_note}), \
because the face detector found the face in {seen} of the compared frames",
                    shown(dir, geometry)
                ),
                rows: None,
            }))
        }
    }
}

/// Why a read-back could not run, as the report shows it ("not computed:
/// ..."): the report says so instead of failing the evaluation.
struct NotComputed(String);

/// The read-backs of one evaluation, by video and frame count: the visual
/// section's session is also the first of the every-session table, and an
/// extraction costs more than the rest of the report.
struct ReadBackMemo<'a> {
    done: std::cell::RefCell<Vec<(PathBuf, usize, ReadBack)>>,
    /// Where each read-back's frames are shown.
    progress: &'a dyn eyereplay_core::Progress,
}

impl ReadBackMemo<'_> {
    /// [`read_back`], or what it gave for the same video and frames before.
    fn read_back(
        &self,
        dir: &Path,
        video: &Path,
        models: &Path,
        n: usize,
        fps: f64,
        geometry: &Path,
    ) -> Result<std::result::Result<ReadBack, NotComputed>> {
        if let Some((.., r)) = self
            .done
            .borrow()
            .iter()
            .find(|(v, k, _)| v == video && *k == n)
        {
            return Ok(Ok(r.clone()));
        }
        let frames = ReadBackFrames {
            progress: self.progress,
            planned: n as u64,
            done: Default::default(),
        };
        let r = read_back(dir, video, models, n, fps, geometry, &frames);
        // The rest of its planned frames, however the read went (a 4-s
        // trial then the eye crops, or an error), so the bar keeps to its
        // total.
        let done = frames.done.load(std::sync::atomic::Ordering::Relaxed);
        self.progress.advance(frames.planned.saturating_sub(done));
        let r = r?;
        if let Ok(r) = &r {
            self.done
                .borrow_mut()
                .push((video.to_path_buf(), n, r.clone()));
        }
        Ok(r)
    }
}

/// One read-back's frames on the stage's bar, at most the `planned` ones
/// [`planned_read_back_frames`] counted for it: a close-up read first for
/// 4 s, then whole, reads some frames twice.
struct ReadBackFrames<'a> {
    progress: &'a dyn eyereplay_core::Progress,
    planned: u64,
    done: std::sync::atomic::AtomicU64,
}

impl eyereplay_extract::Progress for ReadBackFrames<'_> {
    fn advance(&self, _video: usize, n: u64) {
        use std::sync::atomic::Ordering::Relaxed;
        let before = self
            .done
            .fetch_update(Relaxed, Relaxed, |d| Some((d + n).min(self.planned)))
            .expect("the closure always returns Some");
        let step = (before + n).min(self.planned) - before;
        if step > 0 {
            self.progress.advance(step);
        }
    }
}

/// What [`read_back`] read from a video.
#[derive(Clone)]
struct ReadBack {
    /// Per-frame `(nx, ny)`, NaN where no open eyes were found.
    n: Vec<[f64; 2]>,
    /// How the eyes were found.
    how: String,
    /// The extractor's rows, when its own pipeline found the eyes.
    rows: Option<Vec<eyereplay_extract::Row>>,
}

/// [`detection_rate`] of the rows' [`row_norm`].
fn rows_detection_rate(rows: &[eyereplay_extract::Row]) -> f64 {
    rows.iter()
        .filter(|r| row_norm(r).iter().all(|v| v.is_finite()))
        .count() as f64
        / rows.len().max(1) as f64
}

fn detection_rate(n: &[[f64; 2]]) -> f64 {
    n.iter()
        .filter(|p| p[0].is_finite() && p[1].is_finite())
        .count() as f64
        / n.len().max(1) as f64
}

/// A video whose frame count differs from its trajectory is bad input.
/// Its frames are counted in the file (demuxed, not decoded): the count
/// the container states survives a file cut short, which was then scored
/// on the frames it had.
fn check_frame_count(video: &Path, trajectory_frames: usize) -> Result<()> {
    let frames = eyereplay_extract::count_video_packets(video)
        .map_err(|e| Error::input(video, format!("reading the video: {e}")))?;
    if frames != trajectory_frames as u64 {
        return Err(Error::input(
            video,
            format!(
                "{frames} video frames, but its trajectory has {trajectory_frames}: cut short or replaced? (render it again: 'eyereplay generate' with this --out redraws it)"
            ),
        ));
    }
    Ok(())
}

/// A path as shown in the report: relative to the dataset folder when it is
/// inside it (so reports do not depend on where the dataset lives).
fn shown(dir: &Path, p: &Path) -> String {
    p.strip_prefix(dir).unwrap_or(p).display().to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shown_paths_are_relative_inside_the_dataset() {
        assert_eq!(
            shown(Path::new("/data"), Path::new("/data/reading/r.mp4")),
            "reading/r.mp4"
        );
        assert_eq!(shown(Path::new("/data"), Path::new("/x/r.mp4")), "/x/r.mp4");
    }

    #[test]
    fn blinks_widen_by_two_frames_each_side() {
        let dir = tempfile::tempdir().unwrap();
        let traj = dir.path().join("s.csv");
        let mut text = String::from("frame,x,y,blink\n");
        for i in 0..10 {
            text.push_str(&format!("{i},1,1,{}\n", (i == 5) as u8));
        }
        std::fs::write(&traj, text).unwrap();
        let t = VisualTarget {
            video: dir.path().join("s.mp4"),
            trajectory: traj,
            truth: None,
            session: None,
        };
        let c = closed_frames(&t, 10).unwrap();
        let want: Vec<bool> = (0..10).map(|i| (3..=7).contains(&i)).collect();
        assert_eq!(c, want);
    }
}
