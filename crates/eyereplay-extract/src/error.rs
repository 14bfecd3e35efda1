use std::path::PathBuf;

/// Errors of iris extraction. Each renders as one line naming the file and
/// what to do, because the CLI prints them as the whole error message.
#[derive(Debug, thiserror::Error)]
pub enum ExtractError {
    #[error("{path}: cannot open video: {message}")]
    Open { path: PathBuf, message: String },
    #[error("{path}: no video stream (audio-only or not a video file)")]
    NoVideoStream { path: PathBuf },
    #[error("{path}: no video frames could be decoded")]
    NoFrames { path: PathBuf },
    /// Frames given in memory that cannot be read (wrong size, times).
    #[error("frames: {0}")]
    Frames(String),
    #[error("{path}: decoding failed: {message}")]
    Decode { path: PathBuf, message: String },
    #[error("{path}: no face found in any of its {frames} frames")]
    NoFace { path: PathBuf, frames: usize },
    #[error(
        "models not found in {dir}: missing {missing}; run scripts/setup.sh (or `cargo xtask models`) in a checkout. The folder is $EYEREPLAY_MODELS, else the Python package's own models, else $EYEREPLAY_CACHE/models, else .cache/models up from the current folder"
    )]
    ModelsMissing { dir: PathBuf, missing: String },
    #[error("{path}: no sha256 was recorded at its conversion, so it cannot be checked (made by hand or by an older scripts/models.sh); run scripts/setup.sh (or `cargo xtask models`) to convert and record it")]
    ModelUnverified { path: PathBuf },
    #[error("{path}: sha256 {actual}, where {against} is {expected}; run scripts/setup.sh (or `cargo xtask models`)")]
    ModelChecksum {
        path: PathBuf,
        /// Whose hash `expected` is: "the pinned sha256" (a source file or
        /// the runtime library) or the one the conversion recorded.
        against: &'static str,
        expected: String,
        actual: String,
    },
    #[error("ONNX Runtime: {0}")]
    Runtime(String),
    /// An output path that cannot hold what was asked (one CSV file for
    /// several videos).
    #[error("{0}")]
    Output(String),
    /// A network's output of another size than the pinned model's.
    #[error("{model}: output {output} has {got} values, expected {expected}; run scripts/setup.sh (or `cargo xtask models`) to convert it again")]
    ModelOutput {
        model: String,
        output: String,
        got: usize,
        expected: usize,
    },
    #[error("{path}: line {line}: {message}")]
    Reference {
        path: PathBuf,
        line: u64,
        message: String,
    },
    /// An option of the cascade's iris model asked of the attention mesh,
    /// which reads both eyes from its face crop once a frame.
    #[error("{option} applies to the cascade landmarks only (the attention mesh reads the eyes once from its face crop): use {cascade}, or leave {option} out")]
    CascadeOnly {
        option: &'static str,
        /// How the caller asks for the cascade (`--landmarks cascade`).
        cascade: &'static str,
    },
    /// An option out of its range ([`crate::ExtractOptions::validate`]).
    #[error("{0}")]
    Option(String),
    /// Reading a rendered video back failed.
    #[error("{path}: {message}")]
    ReadBack { path: PathBuf, message: String },
    #[error(transparent)]
    Core(#[from] eyereplay_core::CoreError),
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
}

impl From<ort::Error> for ExtractError {
    fn from(e: ort::Error) -> Self {
        ExtractError::Runtime(e.to_string())
    }
}

pub type Result<T, E = ExtractError> = std::result::Result<T, E>;
