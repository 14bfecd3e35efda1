use super::Bars;
use eyereplay_protocols::evaluate_replay;
use std::path::PathBuf;

/// Checks a real-face replay dataset (render.backend = "replay").
///
/// Reads every session video back with the unmodified extractor and prints,
/// per carrier and class (sessions pooled, frames whose eyes were redrawn
/// and read as open): r and amplitude ratio of the read-back n against the
/// trajectory; r against the carrier's own n in the same frames (the
/// carrier's gaze must be gone: near 0); the face detector's score change;
/// and PSNR outside the eye regions against the decoded carrier frames
/// (the rest of the picture untouched, up to encoding). Writes the numbers,
/// per session too, as JSON with --json.
///
/// Checked before any session video is read back: labels.csv against the
/// sessions metadata.json planned, every session's identity, truth and carrier
/// files (a row per frame, carrier frames inside the carrier), each
/// carrier found by its sha256, and --json (a .json name, not the
/// dataset's metadata.json, writable). A session with no frame to compare
/// is n/a, with a warning.
#[derive(clap::Args)]
#[command(after_help = "Examples:\n  \
eyereplay generate --config examples/replay.toml --out out/replay\n  \
eyereplay evaluate-replay out/replay --json out/replay/replay_eval.json")]
pub struct Args {
    /// A dataset folder rendered with render.backend = "replay".
    pub dataset: PathBuf,
    /// Also write every number (per group and per session) to this JSON
    /// file (a file name, where `evaluate --json` and `detect --json` print
    /// to standard output).
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
    /// A carrier video outside the config's paths and the bundled ones
    /// (found by the sha256 the sessions record); repeat for several.
    #[arg(long, value_name = "VIDEO")]
    pub carrier: Vec<PathBuf>,
    /// Extraction and carrier cache (default: $EYEREPLAY_CACHE, else
    /// $XDG_CACHE_HOME/eyereplay, else ~/.cache/eyereplay).
    #[arg(long, value_name = "DIR")]
    pub cache: Option<PathBuf>,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    if let Some(path) = &args.json {
        super::check_json_out(path, "--json", &[&args.dataset], &[])?;
    }
    let cache = super::cache_dir(args.cache.as_deref())?;
    let ev = evaluate_replay(&args.dataset, &args.carrier, &cache, &Bars::default())?;
    println!("{ev}");
    if let Some(path) = &args.json {
        let mut text = serde_json::to_string_pretty(&ev)?;
        text.push('\n');
        eyereplay_core::atomic_write(path, text.as_bytes())?;
    }
    Ok(())
}
