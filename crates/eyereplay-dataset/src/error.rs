use std::path::PathBuf;

/// Errors reading or writing a dataset folder. Every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum DatasetError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// A file that exists but does not hold what the format says.
    #[error("{path}: {message}")]
    Invalid { path: PathBuf, message: String },
    /// metadata.json of a format this build does not read.
    #[error("{path}: dataset format version {found}, but this eyereplay ({tool}) reads version {expected}; regenerate the dataset with this version, or read it with the eyereplay that wrote it ({written_by})")]
    Version {
        path: PathBuf,
        found: u32,
        expected: u32,
        tool: &'static str,
        written_by: String,
    },
    /// A session path (as in labels.csv) that would leave the dataset
    /// folder: empty, absolute or with `..` (no file named: the caller
    /// knows which file held it).
    #[error("bad session file '{0}'")]
    SessionFile(String),
    #[error(transparent)]
    Core(#[from] eyereplay_core::CoreError),
    #[error(transparent)]
    Prepare(#[from] eyereplay_prepare::PrepareError),
}

impl DatasetError {
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        DatasetError::Io {
            path: path.into(),
            source,
        }
    }
    pub fn invalid(path: impl Into<PathBuf>, message: impl Into<String>) -> Self {
        DatasetError::Invalid {
            path: path.into(),
            message: message.into(),
        }
    }
}

/// Reads a whole text file; a missing file says what folder was expected.
pub(crate) fn read_text(path: &std::path::Path) -> Result<String, DatasetError> {
    std::fs::read_to_string(path).map_err(|e| {
        if e.kind() == std::io::ErrorKind::NotFound {
            DatasetError::invalid(
                path,
                "not found (is this a dataset folder written by 'eyereplay prepare' or 'generate'?)",
            )
        } else {
            DatasetError::io(path, e)
        }
    })
}
