//! `eyereplay models check`: the face and iris networks.

use anyhow::Result;
use clap::{Parser, Subcommand};
use eyereplay_extract as ex;
use std::path::PathBuf;

#[derive(Parser, Debug)]
#[command(
    about = "Check the face/iris models used by 'eyereplay extract'",
    long_about = "Check the face/iris models used by 'eyereplay extract': the sha256 of their \
sources and one inference per model. The models are fetched and converted by \
scripts/setup.sh (it runs scripts/models.sh; `cargo xtask models [--dir DIR]` in a checkout \
does the same), into $EYEREPLAY_MODELS, else $EYEREPLAY_CACHE/models, else .cache/models. \
A network whose conversion recorded no sha256 fails the check (every job still runs it, \
with a line saying it is not checked).",
    after_help = "Examples:\n  \
# sha256 of the sources, one inference per model\n  \
eyereplay models check\n  \
eyereplay models check --dir /opt/eyereplay-models"
)]
pub struct Args {
    #[command(subcommand)]
    pub action: Action,
}

#[derive(Subcommand, Debug)]
pub enum Action {
    /// Verify the models folder and run each model once.
    Check {
        /// Models folder [default: $EYEREPLAY_MODELS, else the Python
        /// package's, else $EYEREPLAY_CACHE/models, else .cache/models up
        /// from the current folder].
        #[arg(long)]
        dir: Option<PathBuf>,
    },
}

pub fn run(a: Args) -> Result<()> {
    match a.action {
        Action::Check { dir } => {
            let dir = dir.unwrap_or_else(ex::default_models_dir);
            println!("models in {}:", dir.display());
            for line in ex::check_models_strict(&dir)? {
                println!("  {line}");
            }
            Ok(())
        }
    }
}
