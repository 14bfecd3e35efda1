use std::path::PathBuf;

/// Errors of the evaluation stage. Each message is one line and names the
/// file at fault where there is one.
#[derive(Debug, thiserror::Error)]
pub enum EvalError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A dataset file is missing, unreadable or says something impossible.
    #[error("{path}: {message}")]
    Dataset { path: PathBuf, message: String },
    #[error(transparent)]
    Core(#[from] eyereplay_core::CoreError),
    #[error(transparent)]
    Format(#[from] eyereplay_dataset::DatasetError),
    /// Inputs to a statistic are unusable (empty sample, NaN, length mismatch).
    #[error("{0}")]
    Stats(String),
    #[error("plot {name}: {message}")]
    Plot { name: String, message: String },
}

/// A drawing backend's failure while a figure is drawn; [`EvalError::Plot`]
/// adds the figure's name.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub(crate) struct DrawError(pub String);

impl EvalError {
    pub fn dataset(path: impl Into<PathBuf>, message: impl Into<String>) -> Self {
        EvalError::Dataset {
            path: path.into(),
            message: message.into(),
        }
    }
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        EvalError::Io {
            path: path.into(),
            source,
        }
    }
}
