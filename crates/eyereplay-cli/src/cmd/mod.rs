//! One module per subcommand; each exposes `Args` (clap) and `run`.
pub mod evaluate;
pub mod prepare;

use eyereplay_prepare::PrepareError;
use std::path::{Path, PathBuf};

/// The iris CSV for a video source of a dataset config.
pub fn video_source_csv(video: &Path) -> Result<PathBuf, PrepareError> {
    Err(PrepareError::Source {
        id: video.display().to_string(),
        message:
            "video sources need the extractor; run `eyereplay extract` and use format = \"extract\""
                .into(),
    })
}
