use std::path::PathBuf;

/// Everything that can go wrong in the pipeline, by layer. Each message is
/// one line that names the file or setting at fault.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error(transparent)]
    Core(#[from] eyereplay_core::CoreError),
    #[error(transparent)]
    Source(#[from] eyereplay_sources::SourceError),
    #[error(transparent)]
    Prepare(#[from] eyereplay_prepare::PrepareError),
    #[error(transparent)]
    Dataset(#[from] eyereplay_dataset::DatasetError),
    #[error(transparent)]
    Extract(#[from] eyereplay_extract::ExtractError),
    #[error(transparent)]
    Render(#[from] eyereplay_render::RenderError),
    #[error(transparent)]
    Eval(#[from] eyereplay_eval::EvalError),
    #[error(transparent)]
    Face(#[from] eyereplay_face::FaceError),
    #[error(transparent)]
    Replay(#[from] eyereplay_replay::ReplayError),
    #[error(transparent)]
    Detect(#[from] eyereplay_detect::DetectError),
    #[error(transparent)]
    Backend(#[from] eyereplay_backends::BackendError),
    /// A file or folder the job needs is missing or unusable.
    #[error("{path}: {message}")]
    Input { path: PathBuf, message: String },
    /// An option or setting out of range.
    #[error("{0}")]
    Setting(String),
}

impl Error {
    pub fn input(path: impl Into<PathBuf>, message: impl Into<String>) -> Self {
        Error::Input {
            path: path.into(),
            message: message.into(),
        }
    }
    pub fn io(path: &std::path::Path, e: std::io::Error) -> Self {
        Error::input(path, e.to_string())
    }
}

pub type Result<T, E = Error> = std::result::Result<T, E>;
