use std::path::PathBuf;

/// Everything that can go wrong while rendering through a browser. Each
/// message is one line, so the command can print it as-is.
#[derive(Debug, thiserror::Error)]
pub enum BrowserError {
    /// No usable headless browser (the message names the Debian package).
    #[error("no headless Chromium found ({searched}); install it: apt-get install chromium-headless-shell")]
    BrowserMissing { searched: String },
    #[error("browser {program} did not start: {message}")]
    Launch { program: PathBuf, message: String },
    /// The browser answered a DevTools command with an error, or lacks a
    /// command the frame-exact capture needs.
    #[error("DevTools {method} failed: {message}")]
    Protocol { method: String, message: String },
    /// The browser stopped answering within the command timeout.
    #[error("browser did not answer {method} within {timeout_s:.1} s")]
    Timeout { method: String, timeout_s: f64 },
    /// The DevTools connection closed (the browser exited or crashed).
    #[error("browser connection lost: {0}")]
    Disconnected(String),
    #[error("page {url} could not be loaded: {message}")]
    Load { url: String, message: String },
    #[error("page {url} not ready after {waited_s:.1} s (waiting for {condition}){detail}")]
    NotReady {
        url: String,
        waited_s: f64,
        condition: String,
        /// Empty, or "; last error: ..." from the readiness expression.
        detail: String,
    },
    #[error("page crashed ({0})")]
    Crashed(String),
    #[error("page navigated away to {url}")]
    NavigatedAway { url: String },
    #[error("page has no WebGL (getContext('webgl') returned null); the browser flags need --enable-unsafe-swiftshader")]
    NoWebGl,
    /// A screenshot the capture could not use.
    #[error("frame {frame}: {message}")]
    Frame { frame: usize, message: String },
    /// The `truth_js` expression returned something that is not a flat
    /// object of numbers with the same keys in every frame.
    #[error("truth_js at frame {frame}: {message}")]
    Truth { frame: usize, message: String },
    #[error("invalid browser settings: {0}")]
    Settings(String),
    #[error("invalid input: {0}")]
    Input(String),
    /// A frame whose test-page codes cannot be read (too small, no code
    /// strip, a checksum that does not match).
    #[error("{0}")]
    Codes(String),
    /// A screenshot that does not decode ([`crate::decode_image`]); the
    /// capture reports it as [`BrowserError::Frame`] with the frame.
    #[error("{0}")]
    Image(String),
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// Any error of one session, with the session's name in front.
    #[error("session {session}: {source}")]
    Session {
        session: String,
        #[source]
        source: Box<BrowserError>,
    },
    #[error(transparent)]
    Render(#[from] eyereplay_render::RenderError),
    #[error(transparent)]
    Core(#[from] eyereplay_core::CoreError),
}

/// An error message the browser itself sent back: a DevTools command's
/// error message, or the first line of a JavaScript exception.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct RemoteError(pub String);

impl BrowserError {
    pub(crate) fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        BrowserError::Io {
            path: path.into(),
            source,
        }
    }

    pub(crate) fn protocol(method: &str, message: impl Into<String>) -> Self {
        BrowserError::Protocol {
            method: method.into(),
            message: message.into(),
        }
    }

    /// Puts the session's name in front (once).
    pub fn in_session(self, session: &str) -> Self {
        match self {
            e @ BrowserError::Session { .. } => e,
            e => BrowserError::Session {
                session: session.into(),
                source: Box::new(e),
            },
        }
    }
}
