use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum PrepareError {
    #[error("{path}: {message}")]
    Config { path: PathBuf, message: String },
    #[error("{id}: {message}")]
    Source { id: String, message: String },
    #[error("class '{class}': {message}")]
    Class { class: String, message: String },
    #[error(transparent)]
    Read(#[from] eyereplay_sources::SourceError),
    #[error(transparent)]
    Core(#[from] eyereplay_core::CoreError),
}
