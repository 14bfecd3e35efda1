use std::path::PathBuf;

/// Everything that can go wrong while rendering. Each message is one line, so
/// the command can print it as-is.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error("ffmpeg not found ({program}); install it: apt-get install ffmpeg")]
    FfmpegMissing { program: String },
    #[error("ffmpeg failed for {path}: {message}")]
    Ffmpeg { path: PathBuf, message: String },
    #[error("ffprobe failed for {path}: {message}")]
    Probe { path: PathBuf, message: String },
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("invalid input: {0}")]
    Input(String),
    #[error("invalid render parameters: {0}")]
    Params(String),
    #[error(transparent)]
    Dataset(#[from] eyereplay_dataset::DatasetError),
    #[error(transparent)]
    Core(#[from] eyereplay_core::CoreError),
}

impl RenderError {
    pub(crate) fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        RenderError::Io {
            path: path.into(),
            source,
        }
    }
}
