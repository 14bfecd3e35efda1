//! What the face examples share: their arguments and the fitter.
#![allow(dead_code)]

use eyereplay_face::*;
use std::path::PathBuf;

/// `[OUT_DIR] [PHOTO...]`: the output folder (created; `default_out` when
/// not given) and the photos (the bundled ones when none are given).
pub fn out_and_photos(default_out: &str) -> Result<(PathBuf, Vec<PathBuf>)> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let out = PathBuf::from(args.first().map(String::as_str).unwrap_or(default_out));
    std::fs::create_dir_all(&out).map_err(|source| FaceError::Io {
        path: out.clone(),
        source,
    })?;
    Ok((out, photos_from(args.get(1..).unwrap_or_default())))
}

/// `[PHOTO...]`: the photos given, or the bundled ones.
pub fn photos() -> Vec<PathBuf> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    photos_from(&args)
}

fn photos_from(args: &[String]) -> Vec<PathBuf> {
    if args.is_empty() {
        bundled_faces()
    } else {
        args.iter().map(PathBuf::from).collect()
    }
}

/// The canonical mesh and a photo fitter on the default models.
pub fn mesh_and_fitter() -> Result<(CanonicalMesh, PhotoFitter)> {
    let mesh = CanonicalMesh::load(&default_faces_dir().join(MESH_FILE))?;
    let fitter = PhotoFitter::new(&eyereplay_extract::default_models_dir(), mesh.clone())?;
    Ok((mesh, fitter))
}
