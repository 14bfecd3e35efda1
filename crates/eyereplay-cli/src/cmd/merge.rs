//! `eyereplay merge`: finish a dataset rendered in shards.

use anyhow::Result;
use std::path::PathBuf;

/// Finish a dataset rendered in shards: verify every session, write the final
/// metadata.json and the evaluation report.
///
/// Checked first, and nothing written unless all of it holds: labels.csv
/// lists the sessions metadata.json planned; each session's trajectory CSV
/// and truth file have session_frames rows; its video has session_frames
/// frames and the size its identity file records; the identity file is its
/// own. Then metadata.json gets each session's identity, and the report
/// (report/, replaced whole) is made unless --no-evaluate.
#[derive(clap::Args)]
#[command(after_help = "Examples:\n  \
# after every 'generate --shard K/N' finished\n  \
eyereplay merge /shared/data\n  \
eyereplay merge data/ --no-evaluate")]
pub struct Args {
    /// Dataset folder that the shards wrote into.
    pub dir: PathBuf,
    /// Skip the evaluation report.
    #[arg(long)]
    pub no_evaluate: bool,
}

pub fn run(args: Args) -> Result<()> {
    let opts = (!args.no_evaluate).then(eyereplay::EvaluateOptions::default);
    let outcome =
        eyereplay::finalize_with_progress(&args.dir, opts.as_ref(), &super::Bars::default())?;
    super::work_done();
    if let Some(ev) = outcome {
        super::evaluate::print_outcome(&ev, false);
    }
    println!("merged {}", args.dir.display());
    Ok(())
}
