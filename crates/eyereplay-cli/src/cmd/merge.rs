//! `eyereplay merge`: checks that every session of a (sharded) dataset is
//! rendered, then writes the final `labels.csv` and `metadata.json` (with
//! each session's identity parameters and seed) and the evaluation report.

use anyhow::{bail, Context, Result};
use clap::Parser;
use eyereplay_core::atomic_write_with;
use eyereplay_prepare::DatasetMetadata;
use eyereplay_render::{ffprobe_for, is_complete, list_sessions};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Finish a dataset rendered in shards: verify every session, write the final
/// labels.csv and metadata.json, and the evaluation report.
#[derive(clap::Args)]
#[command(after_help = "Examples:\n  \
eyereplay merge /shared/data          # after every 'generate --shard K/N' finished\n  \
eyereplay merge data/ --no-evaluate")]
pub struct Args {
    /// Dataset folder that the shards wrote into.
    pub dir: PathBuf,
    /// Skip the evaluation report.
    #[arg(long)]
    pub no_evaluate: bool,
}

pub fn run(args: Args) -> Result<()> {
    finalize(&args.dir, !args.no_evaluate)?;
    println!("merged {}", args.dir.display());
    Ok(())
}

#[derive(Serialize)]
struct FinalMetadata<'a> {
    #[serde(flatten)]
    dataset: &'a DatasetMetadata,
    render: RenderMetadata,
}

#[derive(Serialize)]
struct RenderMetadata {
    /// Per session: seed, identity (iris, skin, eye shape, lighting, camera),
    /// gaze mapping and video size, as written beside each video.
    sessions: Vec<serde_json::Value>,
}

/// Verifies completeness, writes final labels/metadata, optionally evaluates.
pub fn finalize(dir: &Path, evaluate: bool) -> Result<()> {
    let meta_path = dir.join("metadata.json");
    let text = std::fs::read_to_string(&meta_path).with_context(|| {
        format!(
            "{}: not a dataset folder (run 'eyereplay generate' first)",
            meta_path.display()
        )
    })?;
    // A merged metadata.json carries a "render" section; the dataset part is
    // the same either way.
    let meta: DatasetMetadata = serde_json::from_str(&text)
        .with_context(|| format!("{}: not eyereplay metadata", meta_path.display()))?;
    let jobs = list_sessions(dir, meta.seed)?;
    let ffprobe = ffprobe_for(Path::new("ffmpeg"));
    let missing: Vec<&str> = jobs
        .iter()
        .filter(|j| !is_complete(j, meta.session_frames, &ffprobe))
        .map(|j| j.file.as_str())
        .collect();
    if !missing.is_empty() {
        let shown: Vec<&str> = missing.iter().take(12).copied().collect();
        bail!(
            "{}: {} of {} sessions are not rendered: {}{} (rerun the shard(s) that own them with the same command)",
            dir.display(),
            missing.len(),
            jobs.len(),
            shown.join(", "),
            if missing.len() > shown.len() { ", ..." } else { "" }
        );
    }
    let mut sessions = Vec::with_capacity(jobs.len());
    for j in &jobs {
        let t = std::fs::read_to_string(&j.identity_json)
            .with_context(|| j.identity_json.display().to_string())?;
        let v: serde_json::Value = serde_json::from_str(&t)
            .with_context(|| format!("{}: invalid JSON", j.identity_json.display()))?;
        sessions.push(v);
    }
    let labels = std::fs::read(dir.join("labels.csv")).context("labels.csv")?;
    atomic_write_with(&dir.join("labels.csv"), |w| w.write_all(&labels))?;
    let json = serde_json::to_vec_pretty(&FinalMetadata {
        dataset: &meta,
        render: RenderMetadata { sessions },
    })?;
    atomic_write_with(&meta_path, |w| {
        w.write_all(&json)?;
        w.write_all(b"\n")
    })?;
    if evaluate {
        #[derive(Parser)]
        struct Wrap {
            #[command(flatten)]
            args: crate::cmd::evaluate::Args,
        }
        let w = Wrap::try_parse_from(["evaluate".as_ref(), dir.as_os_str()])?;
        crate::cmd::evaluate::run(w.args)?;
    }
    Ok(())
}
