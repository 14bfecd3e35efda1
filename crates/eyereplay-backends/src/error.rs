use eyereplay_core::first_few;
use std::path::PathBuf;

/// Everything that can stop a dataset render, by layer; each message is one
/// line naming the file or setting at fault.
#[derive(Debug, thiserror::Error)]
pub enum BackendError {
    #[error(transparent)]
    Core(#[from] eyereplay_core::CoreError),
    #[error(transparent)]
    Dataset(#[from] eyereplay_dataset::DatasetError),
    #[error(transparent)]
    Extract(#[from] eyereplay_extract::ExtractError),
    #[error(transparent)]
    Render(#[from] eyereplay_render::RenderError),
    #[error(transparent)]
    Face(#[from] eyereplay_face::FaceError),
    #[error(transparent)]
    Replay(#[from] eyereplay_replay::ReplayError),
    #[cfg(feature = "browser")]
    #[error(transparent)]
    Browser(#[from] eyereplay_browser::BrowserError),
    #[error(transparent)]
    Eval(#[from] eyereplay_eval::EvalError),
    /// A file or folder the render needs is missing or unusable.
    #[error("{path}: {message}")]
    Input { path: PathBuf, message: String },
    /// A `[render]` setting out of range or not available in this build.
    #[error("{0}")]
    Setting(String),
    /// Some sessions' trajectories cannot be read: nothing was drawn.
    #[error("{} session(s) cannot be read, so none was drawn: {}", .0.len(), first_few(.0, 3, "; "))]
    UnreadableSessions(Vec<String>),
    /// Some sessions failed; the others were written. Rerun to retry.
    #[error("{} session(s) failed (rerun the same command to retry): {}", .0.len(), first_few(.0, 3, "; "))]
    SessionsFailed(Vec<String>),
}

impl BackendError {
    pub fn input(path: impl Into<PathBuf>, message: impl Into<String>) -> Self {
        BackendError::Input {
            path: path.into(),
            message: message.into(),
        }
    }
    pub(crate) fn io(path: &std::path::Path, e: std::io::Error) -> Self {
        BackendError::input(path, e.to_string())
    }
}

pub type Result<T, E = BackendError> = std::result::Result<T, E>;
