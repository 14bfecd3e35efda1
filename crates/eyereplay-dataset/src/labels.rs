//! `labels.csv`: one row per session, `file,label,class,sources` (label 1 =
//! reading, 0 = conversation; sources `;`-separated).

use crate::error::read_text;
use crate::layout::{session_paths, SessionPaths, LABELS_FILE};
use crate::table::Table;
use crate::DatasetError;
use eyereplay_core::GazeClass;
use std::path::Path;

pub const LABELS_HEADER: &str = "file,label,class,sources";

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LabelRow {
    /// Session CSV relative to the dataset folder.
    pub file: String,
    pub class: GazeClass,
    /// Source ids that appear in the session, in order of appearance.
    pub sources: Vec<String>,
}

impl LabelRow {
    pub fn label(&self) -> u8 {
        self.class.label()
    }
}

/// Reads labels.csv, checking that each label matches its class and each
/// file stays inside the dataset folder.
pub fn read_labels(dir: &Path) -> Result<Vec<LabelRow>, DatasetError> {
    let path = dir.join(LABELS_FILE);
    let text = read_text(&path)?;
    let t = Table::parse(&text, &path)?;
    let expected = format!(
        " (expected {LABELS_HEADER}; found {})",
        t.headers.iter().collect::<Vec<_>>().join(",")
    );
    let (cf, cl, cc) = (
        t.col("file", &expected)?,
        t.col("label", &expected)?,
        t.col("class", &expected)?,
    );
    let cs = t.optional_col("sources");
    let mut out = Vec::with_capacity(t.records.len());
    for (line, rec) in &t.records {
        let line = *line;
        let file = t.text(rec, cf).to_string();
        session_paths(dir, &file, line)?;
        let class: GazeClass = t
            .text(rec, cc)
            .parse()
            .map_err(|e: String| DatasetError::invalid(&path, format!("line {line}: {e}")))?;
        let label = t.text(rec, cl);
        if label != class.label().to_string() {
            return Err(DatasetError::invalid(
                &path,
                format!(
                    "line {line}: label '{label}' does not match class '{class}' (expected {})",
                    class.label()
                ),
            ));
        }
        let sources = cs
            .map(|c| t.text(rec, c))
            .filter(|s| !s.is_empty())
            .map(|s| s.split(';').map(str::to_string).collect())
            .unwrap_or_default();
        out.push(LabelRow {
            file,
            class,
            sources,
        });
    }
    Ok(out)
}

/// The files of every session in labels.csv order.
pub fn session_paths_of(dir: &Path, labels: &[LabelRow]) -> Vec<SessionPaths> {
    labels
        .iter()
        .map(|l| SessionPaths::new(dir, &l.file).expect("read_labels checked the path"))
        .collect()
}

/// Writes labels.csv atomically.
pub fn write_labels(dir: &Path, rows: &[LabelRow]) -> Result<(), DatasetError> {
    eyereplay_core::atomic_write_with(&dir.join(LABELS_FILE), |w| {
        writeln!(w, "{LABELS_HEADER}")?;
        for r in rows {
            writeln!(
                w,
                "{},{},{},{}",
                r.file,
                r.label(),
                r.class,
                csv_cell(&r.sources.join(";"))
            )?;
        }
        Ok(())
    })?;
    Ok(())
}

/// Quotes a CSV cell when it needs it.
fn csv_cell(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_round_trip_with_quoted_sources() {
        let dir = tempfile::tempdir().unwrap();
        let rows = vec![
            LabelRow {
                file: "reading/reading_0000.csv".into(),
                class: GazeClass::Reading,
                sources: vec!["a,b.csv#1".into(), "c.csv".into()],
            },
            LabelRow {
                file: "conversation/conversation_0000.csv".into(),
                class: GazeClass::Conversation,
                sources: vec![],
            },
        ];
        write_labels(dir.path(), &rows).unwrap();
        let text = std::fs::read_to_string(dir.path().join(LABELS_FILE)).unwrap();
        assert_eq!(
            text,
            "file,label,class,sources\nreading/reading_0000.csv,1,reading,\"a,b.csv#1;c.csv\"\nconversation/conversation_0000.csv,0,conversation,\n"
        );
        assert_eq!(read_labels(dir.path()).unwrap(), rows);
    }

    #[test]
    fn bad_labels_name_the_file_and_line() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join(LABELS_FILE);
        for (text, want) in [
            (
                "file,label,class\nr.csv,0,reading\n",
                "line 2: label '0' does not match",
            ),
            ("file,class\nr.csv,reading\n", "missing column 'label'"),
            (
                "file,label,class\n../r.csv,1,reading\n",
                "line 2: bad session file",
            ),
            ("file,label,class\nr.csv,1,poetry\n", "line 2:"),
        ] {
            std::fs::write(&p, text).unwrap();
            let e = read_labels(dir.path()).unwrap_err().to_string();
            assert!(e.contains("labels.csv") && e.contains(want), "{e}");
        }
    }
}
