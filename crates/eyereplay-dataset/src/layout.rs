//! Where every file of a dataset lives. The only place that spells the
//! dataset's file names.
//!
//! ```text
//! DIR/
//!   labels.csv, metadata.json
//!   pool/<class>.csv
//!   pool/<class>_head.csv                 source head pose per pool frame (face mode, head_motion = "source")
//!   <class>/<class>_NNNN.csv              the session trajectory
//!   <class>/<class>_NNNN.mp4              its rendered video
//!   <class>/<class>_NNNN_truth.csv        the renderer's per-frame ground truth
//!   <class>/<class>_NNNN_identity.json    the rendered identity and eye geometry
//!   report/index.html, report/metrics.json
//!   run.log                               `generate`'s per-stage timings
//! ```

use crate::DatasetError;
use eyereplay_core::GazeClass;
use std::path::{Path, PathBuf};

pub const LABELS_FILE: &str = "labels.csv";
pub const METADATA_FILE: &str = "metadata.json";
pub const REPORT_DIR: &str = "report";
/// The folder of the class pools (`pool/<class>.csv`).
pub const POOL_DIR: &str = "pool";
/// `generate`'s per-stage timings, appended by every run and shard.
pub const RUN_LOG_FILE: &str = "run.log";

/// `<class>/<class>_NNNN.csv`, relative to the dataset folder.
pub fn session_file(class: GazeClass, index: usize) -> String {
    format!("{}/{}_{:04}.csv", class.name(), class.name(), index)
}

/// The index of a session CSV's file name (`<class>_NNNN.csv` of `class`),
/// the inverse of [`session_file`]; `None` for any other file.
pub fn session_index(class: GazeClass, file_name: &str) -> Option<usize> {
    let num = file_name
        .strip_prefix(class.name())?
        .strip_prefix('_')?
        .strip_suffix(".csv")?;
    (num.len() == 4 && num.bytes().all(|b| b.is_ascii_digit()))
        .then(|| num.parse().ok())
        .flatten()
}

/// `pool/<class>.csv`, relative to the dataset folder.
pub fn pool_file(class: GazeClass) -> String {
    format!("{POOL_DIR}/{}.csv", class.name())
}

/// `pool/<class>_head.csv`, relative to the dataset folder: the head pose
/// of each pool frame's source (full-face mode with `head_motion =
/// "source"`).
pub fn pool_head_file(class: GazeClass) -> String {
    format!("{POOL_DIR}/{}_head.csv", class.name())
}

/// The files of one session, from its CSV path relative to the dataset
/// folder (as in labels.csv).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SessionPaths {
    /// Relative path as in labels.csv, e.g. `reading/reading_0003.csv`.
    pub file: String,
    pub csv: PathBuf,
    pub mp4: PathBuf,
    pub truth: PathBuf,
    pub identity_json: PathBuf,
}

impl SessionPaths {
    /// Paths of session `file` (relative) in dataset `dir`. The relative
    /// path must stay inside the dataset: no absolute paths, no `..`
    /// ([`DatasetError::SessionFile`] otherwise).
    pub fn new(dir: &Path, file: &str) -> Result<Self, DatasetError> {
        if file.is_empty() || Path::new(file).is_absolute() || file.contains("..") {
            return Err(DatasetError::SessionFile(file.to_string()));
        }
        Ok(Self::of_csv(&dir.join(file), file))
    }

    /// Paths beside any session-like CSV (e.g. one a user passes by hand).
    pub fn beside(csv: &Path) -> Self {
        Self::of_csv(csv, &csv.display().to_string())
    }

    /// Paths beside a video (`X.mp4` -> `X.csv`, `X_truth.csv`,
    /// `X_identity.json`).
    pub fn beside_video(mp4: &Path) -> Self {
        Self::beside(&mp4.with_extension("csv"))
    }

    fn of_csv(csv: &Path, file: &str) -> Self {
        let stem = csv
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let parent = csv.parent().unwrap_or(Path::new("")).to_path_buf();
        SessionPaths {
            file: file.to_string(),
            mp4: parent.join(format!("{stem}.mp4")),
            truth: parent.join(format!("{stem}_truth.csv")),
            identity_json: parent.join(format!("{stem}_identity.json")),
            csv: csv.to_path_buf(),
        }
    }

    /// The full-face mode's head ground truth, beside the truth CSV
    /// (`X_head.csv`).
    pub fn head_csv(&self) -> PathBuf {
        self.beside_truth("_head.csv")
    }

    /// The replay mode's `<stem>_carrier.csv`: the carrier frame each
    /// output frame shows, and whether its eyes were redrawn.
    pub fn carrier_csv(&self) -> PathBuf {
        self.beside_truth("_carrier.csv")
    }

    fn beside_truth(&self, suffix: &str) -> PathBuf {
        let name = self
            .truth
            .file_name()
            .map(|n| n.to_string_lossy().replace("_truth.csv", suffix))
            .unwrap_or_else(|| suffix.trim_start_matches('_').into());
        self.truth.with_file_name(name)
    }

    /// The files a render writes for the session, whichever the mode (what
    /// an interrupted render may have left half-written, and what a
    /// re-render replaces): video, truth and identity, and the full-face
    /// mode's head CSV and the replay mode's carrier CSV.
    pub fn outputs(&self) -> [PathBuf; 5] {
        [
            self.mp4.clone(),
            self.truth.clone(),
            self.identity_json.clone(),
            self.head_csv(),
            self.carrier_csv(),
        ]
    }
}

/// Checks a labels.csv path cell, naming the labels file on error.
pub(crate) fn session_paths(
    dir: &Path,
    file: &str,
    line: usize,
) -> Result<SessionPaths, DatasetError> {
    SessionPaths::new(dir, file)
        .map_err(|e| DatasetError::invalid(dir.join(LABELS_FILE), format!("line {line}: {e}")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_follow_the_documented_layout() {
        assert_eq!(
            session_file(GazeClass::Reading, 3),
            "reading/reading_0003.csv"
        );
        assert_eq!(pool_file(GazeClass::Conversation), "pool/conversation.csv");
        let p = SessionPaths::new(Path::new("/d"), "reading/reading_0003.csv").unwrap();
        assert_eq!(p.mp4, PathBuf::from("/d/reading/reading_0003.mp4"));
        assert_eq!(p.truth, PathBuf::from("/d/reading/reading_0003_truth.csv"));
        assert_eq!(
            p.identity_json,
            PathBuf::from("/d/reading/reading_0003_identity.json")
        );
        assert_eq!(
            SessionPaths::beside_video(Path::new("x/s.mp4")).identity_json,
            PathBuf::from("x/s_identity.json")
        );
        for bad in ["", "/etc/passwd", "../x.csv", "a/../../b.csv"] {
            assert!(SessionPaths::new(Path::new("/d"), bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn session_index_inverts_session_file() {
        for (class, i) in [(GazeClass::Reading, 0), (GazeClass::Conversation, 1234)] {
            let f = session_file(class, i);
            let name = f.rsplit('/').next().unwrap();
            assert_eq!(session_index(class, name), Some(i));
        }
        assert_eq!(
            session_index(GazeClass::Reading, "reading_0001_truth.csv"),
            None
        );
        assert_eq!(
            session_index(GazeClass::Reading, "conversation_0001.csv"),
            None
        );
        assert_eq!(session_index(GazeClass::Reading, "reading_01.csv"), None);
        assert_eq!(session_index(GazeClass::Reading, "reading_+001.csv"), None);
    }
}

/// The dataset folder (the one with `metadata.json`) that holds `path`
/// at its top level or in one of its class folders (resolved as the OS
/// resolves it, where the folder exists); `None` outside any dataset.
pub fn dataset_holding(path: &Path) -> Option<PathBuf> {
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let folder = parent
        .canonicalize()
        .unwrap_or_else(|_| parent.to_path_buf());
    let in_class_folder = is_class_folder(&folder);
    folder
        .ancestors()
        .take(if in_class_folder { 2 } else { 1 })
        .find(|d| d.join(METADATA_FILE).is_file())
        .map(Path::to_path_buf)
}

/// Whether `dir` is named as a class folder (`reading`, `conversation`).
fn is_class_folder(dir: &Path) -> bool {
    dir.file_name()
        .is_some_and(|n| GazeClass::ALL.iter().any(|c| n == c.name()))
}

/// Whether `path` is a session's file (in a class folder of a dataset),
/// not one of the dataset's own.
pub fn is_session_file(path: &Path) -> bool {
    path.parent().is_some_and(is_class_folder) && dataset_holding(path).is_some()
}

/// Whether `name` is one a dataset folder holds at its top level before
/// its `metadata.json` is written (a run stopped part way): a class
/// folder, the pools, the labels, the report or `generate`'s `run.log`.
fn own_top_level(name: &str) -> bool {
    GazeClass::ALL.iter().any(|c| c.name() == name)
        || [
            POOL_DIR,
            LABELS_FILE,
            METADATA_FILE,
            REPORT_DIR,
            RUN_LOG_FILE,
        ]
        .contains(&name)
}

/// Checks, before any work, that `out` may receive a dataset: it does not
/// exist yet, is empty, holds a dataset (its `metadata.json`), or holds
/// only what a stopped run of eyereplay leaves. A folder of anything else
/// is refused, since writing the dataset removes session files beyond the
/// new count and replaces `labels.csv` and the report.
pub fn check_output_folder(out: &Path) -> Result<(), DatasetError> {
    if out.is_file() {
        return Err(DatasetError::invalid(
            out,
            "is a file, not a folder; give a folder for the dataset",
        ));
    }
    if !out.is_dir() || out.join(METADATA_FILE).is_file() {
        return Ok(());
    }
    let entries = std::fs::read_dir(out).map_err(|e| DatasetError::io(out, e))?;
    // Hidden names: temporary files of an interrupted write, and what a
    // file manager leaves.
    let mut foreign: Vec<String> = entries
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| !n.starts_with('.') && !own_top_level(n))
        .collect();
    if foreign.is_empty() {
        return Ok(());
    }
    foreign.sort();
    Err(DatasetError::invalid(
        out,
        format!(
            "holds files that are not part of an eyereplay dataset ({}) and no {METADATA_FILE}; give a new or empty folder",
            eyereplay_core::first_few(&foreign, 3, ", ")
        ),
    ))
}

#[cfg(test)]
mod output_folder_tests {
    use super::*;

    #[test]
    fn only_new_empty_or_dataset_folders_receive_a_dataset() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("ds");
        // Not there yet, then empty.
        check_output_folder(&out).unwrap();
        std::fs::create_dir(&out).unwrap();
        check_output_folder(&out).unwrap();
        // What a run stopped before metadata.json leaves.
        std::fs::create_dir(out.join("reading")).unwrap();
        std::fs::write(out.join(RUN_LOG_FILE), "run 1\n").unwrap();
        std::fs::write(out.join(".labels.csv.123.tmp"), "").unwrap();
        check_output_folder(&out).unwrap();
        // A folder of the user's own files.
        std::fs::write(out.join("notes.txt"), "mine").unwrap();
        let e = check_output_folder(&out).unwrap_err().to_string();
        assert!(
            e.contains("notes.txt") && e.contains("new or empty folder"),
            "{e}"
        );
        // ... unless it is a dataset already.
        std::fs::write(out.join(METADATA_FILE), "{}").unwrap();
        check_output_folder(&out).unwrap();
        let file = dir.path().join("f.txt");
        std::fs::write(&file, "x").unwrap();
        let e = check_output_folder(&file).unwrap_err().to_string();
        assert!(e.contains("is a file, not a folder"), "{e}");
    }

    #[test]
    fn a_file_is_placed_in_its_dataset_by_the_metadata_above_it() {
        let dir = tempfile::tempdir().unwrap();
        let ds = dir.path().join("ds");
        std::fs::create_dir_all(ds.join("reading")).unwrap();
        std::fs::create_dir_all(ds.join("notes")).unwrap();
        std::fs::write(ds.join(METADATA_FILE), "{}").unwrap();
        let ds = ds.canonicalize().unwrap();
        // Its session files (the class folder there or not) and its own.
        let session = ds.join("reading/reading_0000.mp4");
        assert_eq!(dataset_holding(&session), Some(ds.clone()));
        assert!(is_session_file(&session));
        let planned = ds.join("conversation/conversation_0000.csv");
        assert_eq!(dataset_holding(&planned), Some(ds.clone()));
        assert_eq!(dataset_holding(&ds.join(LABELS_FILE)), Some(ds.clone()));
        assert!(!is_session_file(&ds.join(LABELS_FILE)));
        // A folder of another name inside it, and a file beside it: not.
        assert_eq!(dataset_holding(&ds.join("notes/a.mp4")), None);
        assert_eq!(dataset_holding(&dir.path().join("x.mp4")), None);
    }
}
