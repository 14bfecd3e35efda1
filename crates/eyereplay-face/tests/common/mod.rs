//! Shared by the integration tests: where the assets are, and the
//! skip-or-fail rule of the workspace (without `scripts/setup.sh`'s assets a
//! test prints why and passes, unless CI is set: then it fails).
#![allow(dead_code)]

use std::path::{Path, PathBuf};

pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

pub fn skip_or_fail(what: &str) {
    if std::env::var_os("CI").is_some() {
        panic!("{what} is missing; run scripts/setup.sh");
    }
    eprintln!("SKIPPED: {what} is missing; run scripts/setup.sh");
}

pub fn faces_file(name: &str) -> Option<PathBuf> {
    let p = root().join(".cache/faces").join(name);
    if p.is_file() {
        Some(p)
    } else {
        skip_or_fail(&p.display().to_string());
        None
    }
}

pub fn models() -> Option<PathBuf> {
    let dir = root().join(".cache/models");
    if eyereplay_extract::missing_files(&dir).is_empty() {
        Some(dir)
    } else {
        skip_or_fail(&format!("models in {}", dir.display()));
        None
    }
}

pub fn mesh() -> Option<eyereplay_face::CanonicalMesh> {
    let p = faces_file(eyereplay_face::MESH_FILE)?;
    Some(eyereplay_face::CanonicalMesh::load(&p).expect("mesh parses"))
}

/// The bundled photos.
pub const PHOTOS: [&str; 6] = eyereplay_face::BUNDLED_FACES;
