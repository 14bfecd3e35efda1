//! Finishing a dataset once every session is rendered (on one machine, or
//! by every shard of a cluster job): check completeness, write the final
//! `metadata.json` with each session's identity, and evaluate.

use crate::evaluate::{evaluate_with_progress, EvaluateOptions, EvaluateOutcome};
use crate::{Error, Result};
use eyereplay_backends::{csv_data_rows, is_complete, why_incomplete};
use eyereplay_core::GazeClass;
use eyereplay_dataset::{
    read_metadata, write_metadata, DatasetMetadata, Metadata, RenderMetadata, SessionIdentity,
};
use eyereplay_render::{list_sessions, SessionJob};
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// Sessions of `dir` whose video, truth or identity file is missing or
/// incomplete (labels.csv order).
pub fn missing_sessions(dir: &Path) -> Result<Vec<String>> {
    let meta = read_metadata(dir)?;
    Ok(incomplete(dir, &meta.dataset)?
        .into_iter()
        .map(|j| j.paths.file)
        .collect())
}

fn incomplete(dir: &Path, meta: &DatasetMetadata) -> Result<Vec<SessionJob>> {
    // Every finished video is read through (some milliseconds each), so
    // the sessions are checked in parallel; `collect` keeps their order.
    Ok(list_sessions(dir, meta.seed)?
        .into_par_iter()
        .filter(|j| !is_complete(j, meta.session_frames))
        .collect())
}

/// Verifies that every session is rendered, writes the final metadata.json
/// (the prepared metadata plus each session's identity and geometry), then
/// evaluates when `evaluate_with` is given.
pub fn finalize(
    dir: &Path,
    evaluate_with: Option<&EvaluateOptions>,
) -> Result<Option<EvaluateOutcome>> {
    finalize_with_progress(dir, evaluate_with, &eyereplay_core::NoProgress)
}

/// [`finalize`], the evaluation's read-backs shown on `progress`
/// ([`crate::evaluate_with_progress`]).
pub fn finalize_with_progress(
    dir: &Path,
    evaluate_with: Option<&EvaluateOptions>,
    progress: &dyn eyereplay_core::Progress,
) -> Result<Option<EvaluateOutcome>> {
    let meta = read_metadata(dir)?;
    let jobs = list_sessions(dir, meta.dataset.seed)?;
    // Everything is checked before metadata.json is rewritten: a merge
    // that fails leaves the dataset as it found it.
    let listed: Vec<(&str, GazeClass)> = jobs
        .iter()
        .map(|j| (j.paths.file.as_str(), j.class))
        .collect();
    check_labels_against_plan(dir, &meta.dataset, &listed)?;
    check_trajectories(dir, &meta.dataset, &jobs)?;
    // Each session's own files (video, truth, identity) before the
    // backend's extra ones: a session not drawn lacks them all, and its
    // video is the one to name.
    let frames = meta.dataset.session_frames;
    // With each session's place in labels.csv: the shard that owns it
    // follows from that (merge is not told the shard count).
    let missing: Vec<(usize, PathBuf, String)> = jobs
        .par_iter()
        .enumerate()
        .filter_map(|(i, j)| why_incomplete(j, frames).map(|(p, why)| (i, p, why)))
        .collect();
    if !missing.is_empty() {
        let shown: Vec<String> = missing
            .iter()
            .take(12)
            .map(|(i, path, why)| {
                format!(
                    "{} (session {i}): {why}",
                    path.strip_prefix(dir).unwrap_or(path).display()
                )
            })
            .collect();
        return Err(Error::input(
            dir,
            format!(
                "{} of {} sessions are not rendered whole: {}{} (rerun the shard(s) that own them with the same command: \
                 with N shards, session i is shard i mod N's)",
                missing.len(),
                jobs.len(),
                shown.join("; "),
                if missing.len() > shown.len() { "; ..." } else { "" }
            ),
        ));
    }
    let meta_path = dir.join(eyereplay_dataset::layout::METADATA_FILE);
    let settings =
        eyereplay_dataset::RenderSettings::from_config(&meta.dataset.config, &meta_path)?;
    check_backend_files(dir, &settings, meta.dataset.session_frames, &jobs)?;
    check_truth_values(
        &jobs,
        settings.backend.kind() == eyereplay_dataset::RenderBackend::Browser,
    )?;
    let sessions = jobs
        .iter()
        .map(|j| {
            let id = SessionIdentity::read(&j.paths.identity_json)?;
            // A file copied from another session would put that
            // session's identity into metadata.json under this one.
            if id.file != j.paths.file {
                return Err(Error::input(
                    &j.paths.identity_json,
                    format!("is the identity of {}, not of {}", id.file, j.paths.file),
                ));
            }
            // A video copied from another session of the same length
            // passes the frame count; its size may not.
            let (w, h) = eyereplay_extract::video_stream_size(&j.paths.mp4)?;
            if (w, h) != (id.width, id.height) {
                return Err(Error::input(
                    &j.paths.mp4,
                    format!(
                        "is {w}x{h} where its identity file says {}x{} (another session's video?)",
                        id.width, id.height
                    ),
                ));
            }
            Ok(id)
        })
        .collect::<Result<Vec<_>>>()?;
    let merged = Metadata {
        dataset: meta.dataset,
        render: Some(RenderMetadata { sessions }),
    };
    write_metadata(dir, &merged)?;
    evaluate_with
        .map(|o| evaluate_with_progress(dir, o, progress))
        .transpose()
}

/// `labels.csv` lists the sessions `metadata.json` planned, in its order
/// and classes: a row lost, cut off, repeated or edited would otherwise be
/// merged (and evaluated) as if it were the dataset. `listed`: each row's
/// session file and class.
pub fn check_labels_against_plan(
    dir: &Path,
    meta: &DatasetMetadata,
    listed: &[(&str, GazeClass)],
) -> Result<()> {
    let planned: Vec<(&str, GazeClass)> = meta
        .sessions
        .iter()
        .map(|s| (s.file.as_str(), s.class))
        .collect();
    if listed == planned.as_slice() {
        return Ok(());
    }
    let show = |e: Option<&(&str, GazeClass)>| match e {
        Some((file, class)) => format!("{file} ({})", class.name()),
        None => "nothing".into(),
    };
    let k = listed
        .iter()
        .zip(&planned)
        .take_while(|(a, b)| a == b)
        .count();
    Err(Error::input(
        dir.join(eyereplay_dataset::layout::LABELS_FILE),
        format!(
            "lists {} sessions where metadata.json plans {}; from session {} on it has {} where the plan has {} (restore it, or prepare the dataset again)",
            listed.len(),
            planned.len(),
            k + 1,
            show(listed.get(k)),
            show(planned.get(k)),
        ),
    ))
}

/// Each session's trajectory CSV (what `labels.csv` points at) is there
/// with its `session_frames` rows.
fn check_trajectories(dir: &Path, meta: &DatasetMetadata, jobs: &[SessionJob]) -> Result<()> {
    let files: Vec<PathBuf> = jobs.iter().map(|j| j.paths.csv.clone()).collect();
    check_rows(
        dir,
        &files,
        meta.session_frames,
        &format!("of {} session trajectories", jobs.len()),
        "prepare the dataset again",
    )
}

/// The backend's own files of each session (the face mode's head CSV, the
/// replay mode's carrier CSV: `extra_outputs_of`) are there with their
/// `session_frames` rows.
fn check_backend_files(
    dir: &Path,
    settings: &eyereplay_dataset::RenderSettings,
    session_frames: usize,
    jobs: &[SessionJob],
) -> Result<()> {
    let files: Vec<PathBuf> = jobs
        .iter()
        .flat_map(|j| {
            eyereplay_backends::extra_outputs_of(settings.backend.kind().name(), &j.paths)
        })
        .collect();
    check_rows(
        dir,
        &files,
        session_frames,
        &format!(
            "of the sessions' own files of the {} backend",
            settings.backend.kind().name()
        ),
        "rerun the shard(s) that own them with the same command",
    )
}

/// Every truth file reads as numbers, finite ones: a damaged or edited
/// one (a `NaN`, a word) passes the row count, and would be merged and
/// then fail, or skew, the evaluation that reads it. The first bad file
/// in the dataset's order is named, with its line.
/// A browser page's truth has its own columns (perhaps none of the
/// renderer's, [`eyereplay_dataset::has_renderer_truth`]): each field is
/// checked to be a finite number.
fn check_truth_values(jobs: &[SessionJob], browser: bool) -> Result<()> {
    let read: Vec<Result<()>> = jobs
        .par_iter()
        .map(|j| {
            if browser {
                eyereplay_dataset::check_truth_numbers(&j.paths.truth)
            } else {
                eyereplay_dataset::read_truth_csv(&j.paths.truth).map(drop)
            }
            .map_err(Into::into)
        })
        .collect();
    read.into_iter().collect()
}

/// Every CSV of `files` has `rows` data rows, or one error listing (up to
/// 12 of) those that do not, named relative to `dir`: "N {what} are not
/// whole (R rows each): ... ({remedy})".
fn check_rows(dir: &Path, files: &[PathBuf], rows: usize, what: &str, remedy: &str) -> Result<()> {
    let bad: Vec<String> = files
        .par_iter()
        .filter_map(|p| {
            let why = match csv_data_rows(p) {
                None => "missing or unreadable".to_string(),
                Some(n) if n == rows => return None,
                Some(n) => format!("{n} rows"),
            };
            let name = p.strip_prefix(dir).unwrap_or(p).display().to_string();
            Some(format!("{name} ({why})"))
        })
        .collect();
    if bad.is_empty() {
        return Ok(());
    }
    Err(Error::input(
        dir,
        format!(
            "{} {what} are not whole ({rows} rows each): {} ({remedy})",
            bad.len(),
            eyereplay_core::first_few(&bad, 12, ", ")
        ),
    ))
}
