use std::path::{Path, PathBuf};

/// Errors of the detector. Each message is one line and names the file at
/// fault where there is one.
#[derive(Debug, thiserror::Error)]
pub enum DetectError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A file is not what it should be (a model, a trajectory).
    #[error("{path}: {message}")]
    File { path: PathBuf, message: String },
    /// Writing a file (through a temporary file and a rename).
    #[error(transparent)]
    Core(#[from] eyereplay_core::CoreError),
    /// Training cannot go on with these examples.
    #[error("training: {0}")]
    Train(String),
}

impl DetectError {
    pub fn io(path: &Path, source: std::io::Error) -> Self {
        DetectError::Io {
            path: path.to_path_buf(),
            source,
        }
    }

    pub fn file(path: &Path, message: impl Into<String>) -> Self {
        DetectError::File {
            path: path.to_path_buf(),
            message: message.into(),
        }
    }
}
