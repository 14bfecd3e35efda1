use std::path::PathBuf;

/// Stages 2-5: calibrate, filter blinks, resample, normalize, slice into sessions.
#[derive(clap::Args)]
pub struct Args {
    /// Dataset config (TOML).
    #[arg(long)]
    pub config: PathBuf,
    /// Output dataset folder.
    #[arg(long)]
    pub out: PathBuf,
    /// Print the plan without writing anything.
    #[arg(long)]
    pub dry_run: bool,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    anyhow::bail!(
        "{}: prepare is being built (config {})",
        args.out.display(),
        args.config.display()
    )
}
