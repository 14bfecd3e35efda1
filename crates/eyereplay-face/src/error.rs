use std::path::PathBuf;

/// Errors of the face crate. Each renders as one line naming the file and
/// the problem, because the CLI prints them as the whole error message.
#[derive(Debug, thiserror::Error)]
pub enum FaceError {
    #[error("{path}: cannot read: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{path}: not a face mesh: {message}")]
    Mesh { path: PathBuf, message: String },
    /// What is wrong with serialized mesh bytes ([`crate::parse_mesh`]);
    /// reading a file turns it into [`FaceError::Mesh`] with the path.
    #[error("{0}")]
    MeshFormat(String),
    /// A `[render.webcam]` range out of its limits
    /// ([`crate::webcam::WebcamRanges::validate`]).
    #[error("{0}")]
    Webcam(String),
    #[error("{path}: cannot read the image: {message}")]
    Unreadable { path: PathBuf, message: String },
    #[error("{path}: no face found in the photo")]
    NoFace { path: PathBuf },
    #[error(
        "{path}: face too small: {height_px:.0} px from forehead to chin, at least {min_px:.0} px needed"
    )]
    FaceTooSmall {
        path: PathBuf,
        height_px: f32,
        min_px: f32,
    },
    #[error("{path}: {message}")]
    Identity { path: PathBuf, message: String },
    #[error("{path}: cannot write PNG: {message}")]
    Png { path: PathBuf, message: String },
    #[error(transparent)]
    Extract(#[from] eyereplay_extract::ExtractError),
    #[error(transparent)]
    Core(#[from] eyereplay_core::CoreError),
    #[error(transparent)]
    Render(#[from] eyereplay_render::RenderError),
    #[error(transparent)]
    Dataset(#[from] eyereplay_dataset::DatasetError),
}

pub type Result<T, E = FaceError> = std::result::Result<T, E>;
