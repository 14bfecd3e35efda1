//! Full-face render mode (issue 12), foundations.

mod error;
mod mesh;

pub use error::{FaceError, Result};
pub use mesh::{
    default_faces_dir, lm, parse as parse_mesh, CanonicalMesh, INNER_LIPS, LEFT_EYE_CONTOUR,
    MESH_FILE, MESH_VERTICES, RIGHT_EYE_CONTOUR,
};
