use std::path::PathBuf;

/// Errors of the source readers. Every variant names the file, and where it
/// can the line, so a bad input is a one-line fix for the user.
#[derive(Debug, thiserror::Error)]
pub enum SourceError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: line {line}: {message}")]
    Line {
        path: PathBuf,
        line: u64,
        message: String,
    },
    #[error("{path}: {message}")]
    File { path: PathBuf, message: String },
    /// A saccade model setting out of range (no file: the reader adds it).
    #[error("{0}")]
    Saccade(String),
    #[error(transparent)]
    Core(#[from] eyereplay_core::CoreError),
}

impl SourceError {
    pub fn file(path: impl Into<PathBuf>, message: impl Into<String>) -> Self {
        SourceError::File {
            path: path.into(),
            message: one_line(message.into()),
        }
    }
    pub fn line(path: impl Into<PathBuf>, line: u64, message: impl Into<String>) -> Self {
        SourceError::Line {
            path: path.into(),
            line,
            message: one_line(message.into()),
        }
    }
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        SourceError::Io {
            path: path.into(),
            source,
        }
    }
}

/// Messages quote cells and headers from the file, which may hold line
/// breaks (a stray quote makes a CSV cell span lines): escaped, so an error
/// stays one line.
fn one_line(message: String) -> String {
    if message.contains(['\n', '\r']) {
        message.replace('\n', "\\n").replace('\r', "\\r")
    } else {
        message
    }
}

/// A cell as quoted in a message: at most 40 characters, escaped.
pub(crate) fn cell(c: &str) -> String {
    let mut out: String = c.chars().take(40).flat_map(char::escape_debug).collect();
    if c.chars().count() > 40 {
        out.push_str("...");
    }
    format!("'{out}'")
}
