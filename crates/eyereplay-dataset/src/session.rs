//! Session trajectory CSVs, `frame,x,y[,blink]` in canvas px, and what a
//! session's frames came from.

use crate::error::read_text;
use crate::metadata::DatasetMetadata;
use crate::pool::{frame_sources, read_pool};
use crate::table::Table;
use crate::DatasetError;
use eyereplay_core::Calibration;
use std::path::Path;

pub use eyereplay_core::{read_session_csv, write_session_csv, write_session_csv_with_blinks};

/// Every session of a dataset has the plan's length (`session_frames` in
/// metadata.json): one of `rows` other rows was cut or edited, and would
/// be drawn or read as a shorter session without a word (`merge` refuses
/// it, after the work). `csv` names the session in the error.
pub fn check_session_rows(csv: &Path, rows: usize, planned: usize) -> Result<(), DatasetError> {
    if rows == planned {
        return Ok(());
    }
    Err(DatasetError::invalid(
        csv,
        format!(
            "{rows} rows where the dataset's sessions have {planned} (metadata.json's \
             session_frames): cut short or edited? (prepare the dataset again)"
        ),
    ))
}

/// The optional `blink` column of a session CSV (`frame,x,y,blink`): `None`
/// when the file has no such column. Accepts 0/1 and true/false in any
/// case (as pandas and spreadsheets write them); an empty cell is 0.
pub fn read_blink_column(path: &Path) -> Result<Option<Vec<bool>>, DatasetError> {
    read_flag_column(path, "blink")
}

/// The optional per-frame `reading` column of a session CSV (sessions of
/// behaviour models: 1 where the person reads), read as
/// [`read_blink_column`] reads `blink`.
pub fn read_reading_column(path: &Path) -> Result<Option<Vec<bool>>, DatasetError> {
    read_flag_column(path, "reading")
}

fn read_flag_column(path: &Path, name: &str) -> Result<Option<Vec<bool>>, DatasetError> {
    let text = read_text(path)?;
    let t = Table::parse(&text, path)?;
    let Some(col) = t.optional_col(name) else {
        return Ok(None);
    };
    let mut out = Vec::with_capacity(t.records.len());
    for (line, rec) in &t.records {
        let cell = t.text(rec, col);
        out.push(match cell.to_ascii_lowercase().as_str() {
            "1" | "true" => true,
            "0" | "false" | "" => false,
            _ => {
                return Err(DatasetError::invalid(
                    path,
                    format!("line {line}: {name} must be 0 or 1, found {cell:?}"),
                ))
            }
        });
    }
    Ok(Some(out))
}

/// The calibration(s) that turned normalized iris positions into a
/// session's canvas positions, frame by frame: the pooled calibration when
/// there is one; else each frame's source calibration, the frame's source
/// found by cutting the session out of the pool's `source` column exactly
/// as the session itself was cut (circular slicing, paper eq. 4).
pub fn session_calibrations(
    dir: &Path,
    meta: &DatasetMetadata,
    session_rel: &str,
    frames: usize,
) -> Result<Vec<Calibration>, DatasetError> {
    if let Some(c) = meta.calibration {
        return Ok(vec![c; frames]);
    }
    let meta_path = dir.join(crate::layout::METADATA_FILE);
    let bad = |m: String| DatasetError::invalid(&meta_path, m);
    let entry = meta.session(session_rel).ok_or_else(|| {
        bad(format!(
            "no pooled calibration, and no entry for '{session_rel}' in 'sessions' to find its per-source calibrations"
        ))
    })?;
    let class = meta.class(entry.class).ok_or_else(|| {
        bad(format!(
            "no class entry '{}' for '{session_rel}'",
            entry.class
        ))
    })?;
    let pool = read_pool(&dir.join(&class.pool_file))?;
    let sources = frame_sources(&pool);
    if sources.is_empty() || class.sessions == 0 {
        return Err(bad(format!("class '{}' has an empty pool", entry.class)));
    }
    let per_frame = eyereplay_prepare::slice_session(&sources, entry.index, class.sessions, frames);
    per_frame
        .iter()
        .map(|src| {
            meta.sources
                .iter()
                .find(|s| s.index == *src as usize)
                .map(|s| s.calibration)
                .ok_or_else(|| bad(format!("no calibration for source {src}")))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blink_column_spellings() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("s.csv");
        std::fs::write(
            &p,
            "frame,x,y,blink\n0,1,2,1\n1,1,2,True\n2,1,2,false\n3,1,2,\n4,1,2,0\n",
        )
        .unwrap();
        assert_eq!(
            read_blink_column(&p).unwrap(),
            Some(vec![true, true, false, false, false])
        );
        std::fs::write(&p, "frame,x,y\n0,1,2\n").unwrap();
        assert_eq!(read_blink_column(&p).unwrap(), None);
        std::fs::write(&p, "frame,x,y,blink\n0,1,2,maybe\n").unwrap();
        let e = read_blink_column(&p).unwrap_err().to_string();
        assert!(
            e.contains("s.csv") && e.contains("line 2") && e.contains("maybe"),
            "{e}"
        );
    }
}
