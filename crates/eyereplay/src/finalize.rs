//! Finishing a dataset once every session is rendered (on one machine, or
//! by every shard of a cluster job): check completeness, write the final
//! `metadata.json` with each session's identity, and evaluate.

use crate::evaluate::{evaluate, EvaluateOptions, EvaluateOutcome};
use crate::{Error, Result};
use eyereplay_backends::is_complete;
use eyereplay_dataset::{
    read_metadata, write_metadata, DatasetMetadata, Metadata, RenderMetadata, SessionIdentity,
};
use eyereplay_render::{list_sessions, SessionJob};
use rayon::prelude::*;
use std::path::Path;

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
    let meta = read_metadata(dir)?;
    let jobs = list_sessions(dir, meta.dataset.seed)?;
    let missing = incomplete(dir, &meta.dataset)?;
    if !missing.is_empty() {
        let shown: Vec<&str> = missing
            .iter()
            .take(12)
            .map(|j| j.paths.file.as_str())
            .collect();
        return Err(Error::input(
            dir,
            format!(
                "{} of {} sessions are not rendered: {}{} (rerun the shard(s) that own them with the same command)",
                missing.len(),
                jobs.len(),
                shown.join(", "),
                if missing.len() > shown.len() { ", ..." } else { "" }
            ),
        ));
    }
    let sessions = jobs
        .iter()
        .map(|j| SessionIdentity::read(&j.paths.identity_json))
        .collect::<std::result::Result<Vec<_>, _>>()?;
    let merged = Metadata {
        dataset: meta.dataset,
        render: Some(RenderMetadata { sessions }),
    };
    write_metadata(dir, &merged)?;
    evaluate_with.map(|o| evaluate(dir, o)).transpose()
}
