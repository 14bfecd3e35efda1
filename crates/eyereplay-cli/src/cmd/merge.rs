//! `eyereplay merge`: finish a dataset rendered in shards.

use anyhow::Result;
use std::path::PathBuf;

/// Finish a dataset rendered in shards: verify every session, write the final
/// labels.csv and metadata.json, and the evaluation report.
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
    if let Some(ev) = eyereplay::finalize(&args.dir, opts.as_ref())? {
        super::evaluate::print_outcome(&ev, false);
    }
    println!("merged {}", args.dir.display());
    Ok(())
}
