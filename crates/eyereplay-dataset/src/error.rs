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

/// Reads a whole text file; a missing file says what folder was expected,
/// or, inside a dataset (a `metadata.json` in its folder or the one above),
/// that a session's file is missing and how it is drawn again.
pub(crate) fn read_text(path: &std::path::Path) -> Result<String, DatasetError> {
    // A dataset file under a file given as the dataset folder: the OS says
    // "Not a directory" of a path the user never typed.
    if let Some(dir) = path.parent().filter(|d| d.is_file()) {
        return Err(DatasetError::invalid(
            dir,
            "a file, not a dataset folder (one written by 'eyereplay prepare' or 'generate')",
        ));
    }
    std::fs::read_to_string(path).map_err(|e| {
        if e.kind() == std::io::ErrorKind::NotFound {
            // A class folder given for its dataset: its labels.csv or
            // metadata.json is the dataset's, one folder up.
            let name = path.file_name().and_then(|n| n.to_str());
            let top = [crate::layout::LABELS_FILE, crate::layout::METADATA_FILE];
            if let (Some(class_dir), true) = (path.parent(), name.is_some_and(|n| top.contains(&n)))
            {
                if crate::layout::is_session_file(path) {
                    let dataset = class_dir.parent().unwrap_or(class_dir);
                    return DatasetError::invalid(
                        class_dir,
                        format!(
                            "a class folder of the dataset {}; give that folder",
                            dataset.display()
                        ),
                    );
                }
            }
            DatasetError::invalid(path, missing_file_hint(path))
        } else {
            DatasetError::io(path, e)
        }
    })
}

fn missing_file_hint(path: &std::path::Path) -> &'static str {
    if crate::layout::is_session_file(path) {
        "not found: a session of this dataset is not rendered whole ('eyereplay generate' with the same --out, or 'eyereplay render --dataset', draws what is missing)"
    } else {
        "not found (is this a dataset folder written by 'eyereplay prepare' or 'generate'?)"
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_missing_file_is_told_by_where_it_is_missing() {
        let dir = tempfile::tempdir().unwrap();
        // A file given as the dataset folder is named as such.
        let file = dir.path().join("m.json");
        std::fs::write(&file, "{}").unwrap();
        let e = read_text(&file.join("metadata.json"))
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with(&format!("{}: a file, not a dataset folder", file.display())),
            "{e}"
        );
        let e = read_text(&dir.path().join("metadata.json"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("is this a dataset folder"), "{e}");
        std::fs::write(dir.path().join("metadata.json"), "{}").unwrap();
        // The dataset's own files keep the first hint.
        let e = read_text(&dir.path().join("labels.csv"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("is this a dataset folder"), "{e}");
        // A class folder given for the dataset (`train ds/reading`): named
        // as such, not as a session to draw again.
        let e = read_text(&dir.path().join("reading/labels.csv"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("reading: a class folder of the dataset") && e.ends_with("give that folder"),
            "{e}"
        );
        let id = dir.path().join("reading/reading_0000_identity.json");
        let e = read_text(&id).unwrap_err().to_string();
        assert!(
            e.contains("is not rendered whole") && e.contains("reading_0000_identity.json"),
            "{e}"
        );
    }
}
