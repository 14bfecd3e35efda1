//! JSON files in the cache: what is measured once per carrier.

use crate::error::{ReplayError, Result};
use serde::de::DeserializeOwned;
use serde::Serialize;
use std::path::Path;

/// Reads a cached value; `None` when the file is missing. A file that is
/// not one (`what`) is an error that says how to get rid of it.
pub(crate) fn read_json<T: DeserializeOwned>(path: &Path, what: &str) -> Result<Option<T>> {
    let bytes = match std::fs::read(path) {
        Ok(b) => b,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(ReplayError::io(path, e)),
    };
    serde_json::from_slice(&bytes)
        .map(Some)
        .map_err(|e| ReplayError::Cache {
            path: path.to_path_buf(),
            message: format!("not a {what} ({e}); delete it to measure again"),
        })
}

/// Writes a value atomically.
pub(crate) fn write_json<T: Serialize>(path: &Path, value: &T) -> Result<()> {
    let json = serde_json::to_vec(value).map_err(|e| ReplayError::Cache {
        path: path.to_path_buf(),
        message: e.to_string(),
    })?;
    eyereplay_core::atomic_write(path, &json)?;
    Ok(())
}
