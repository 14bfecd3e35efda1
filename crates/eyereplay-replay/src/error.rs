use std::path::PathBuf;
use thiserror::Error;

/// What can go wrong in the replay mode; each names the file at fault.
#[derive(Debug, Error)]
pub enum ReplayError {
    #[error(transparent)]
    Extract(#[from] eyereplay_extract::ExtractError),
    #[error(transparent)]
    Render(#[from] eyereplay_render::RenderError),
    #[error(transparent)]
    Dataset(#[from] eyereplay_dataset::DatasetError),
    #[error(transparent)]
    Core(#[from] eyereplay_core::CoreError),
    /// A carrier the mode cannot use, with the reason in one line.
    #[error("{}: {reason}", path.display())]
    Carrier { path: PathBuf, reason: String },
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    /// A carrier CSV that is not one (line 1 is the header).
    #[error("{}: line {line}: {message}", path.display())]
    CarrierCsv {
        path: PathBuf,
        line: usize,
        message: String,
    },
}

impl ReplayError {
    pub(crate) fn carrier(path: &std::path::Path, reason: impl Into<String>) -> Self {
        ReplayError::Carrier {
            path: path.to_path_buf(),
            reason: reason.into(),
        }
    }
    pub(crate) fn io(path: &std::path::Path, source: std::io::Error) -> Self {
        ReplayError::Io {
            path: path.to_path_buf(),
            source,
        }
    }
}

pub type Result<T> = std::result::Result<T, ReplayError>;
