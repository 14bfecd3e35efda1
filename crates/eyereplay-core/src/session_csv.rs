//! The per-session trajectory CSV of the dataset: `frame,x,y` in canvas px
//! (paper, section 4 "Per-session output").

use crate::{atomic_write_with, CanvasPos, CoreError};
use serde::{Deserialize, Serialize};
use std::path::Path;

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SessionRow {
    pub frame: u64,
    pub x: f64,
    pub y: f64,
}

/// Writes `frame,x,y` rows atomically. Coordinates are written with 3
/// decimals (1/1000 px), which keeps files small and byte-identical across
/// runs.
pub fn write_session_csv(path: &Path, points: &[CanvasPos]) -> Result<(), CoreError> {
    atomic_write_with(path, |w| {
        w.write_all(b"frame,x,y\n")?;
        for (i, p) in points.iter().enumerate() {
            writeln!(w, "{i},{:.3},{:.3}", p.x_px, p.y_px)?;
        }
        Ok(())
    })
}

/// Reads a `frame,x,y` session CSV, checking that frames count up from 0 and
/// that every coordinate is a finite number.
pub fn read_session_csv(path: &Path) -> Result<Vec<CanvasPos>, CoreError> {
    let mut rdr = csv::ReaderBuilder::new()
        .from_path(path)
        .map_err(|e| csv_err(path, e))?;
    let headers = rdr.headers().map_err(|e| csv_err(path, e))?.clone();
    for need in ["frame", "x", "y"] {
        if !headers.iter().any(|h| h.trim() == need) {
            return Err(CoreError::invalid(
                path,
                format!(
                    "missing column '{need}' (expected header frame,x,y; found {})",
                    headers.iter().collect::<Vec<_>>().join(",")
                ),
            ));
        }
    }
    let mut out = Vec::new();
    for (i, rec) in rdr.deserialize::<SessionRow>().enumerate() {
        let line = i as u64 + 2;
        let row = rec.map_err(|e| CoreError::Parse {
            path: path.into(),
            line,
            message: csv_message(&e),
        })?;
        if row.frame != i as u64 {
            return Err(CoreError::Parse {
                path: path.into(),
                line,
                message: format!("frame {} out of order (expected {i})", row.frame),
            });
        }
        if !row.x.is_finite() || !row.y.is_finite() {
            return Err(CoreError::Parse {
                path: path.into(),
                line,
                message: "x and y must be finite numbers".into(),
            });
        }
        out.push(CanvasPos {
            x_px: row.x,
            y_px: row.y,
        });
    }
    if out.is_empty() {
        return Err(CoreError::invalid(path, "no frames (empty trajectory)"));
    }
    Ok(out)
}

fn csv_err(path: &Path, e: csv::Error) -> CoreError {
    match e.kind() {
        csv::ErrorKind::Io(_) => match e.into_kind() {
            csv::ErrorKind::Io(io) => CoreError::io(path, io),
            _ => unreachable!(),
        },
        _ => CoreError::invalid(path, csv_message(&e)),
    }
}

/// The csv crate's messages repeat position details we already report.
fn csv_message(e: &csv::Error) -> String {
    match e.kind() {
        csv::ErrorKind::Deserialize { err, .. } => match err.field() {
            Some(f) => format!("column {}: {}", f + 1, err.kind()),
            None => err.kind().to_string(),
        },
        csv::ErrorKind::UnequalLengths {
            expected_len, len, ..
        } => format!("has {len} fields, header has {expected_len}"),
        _ => e.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn roundtrip_and_bad_cell() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("s.csv");
        let pts = vec![
            CanvasPos {
                x_px: 1.0,
                y_px: 2.5,
            },
            CanvasPos {
                x_px: 640.1234,
                y_px: 360.0,
            },
        ];
        write_session_csv(&p, &pts).unwrap();
        assert_eq!(
            std::fs::read_to_string(&p).unwrap(),
            "frame,x,y\n0,1.000,2.500\n1,640.123,360.000\n"
        );
        let back = read_session_csv(&p).unwrap();
        assert_eq!(back[1].x_px, 640.123);

        std::fs::write(&p, "frame,x,y\n0,1,2\n1,abc,3\n").unwrap();
        let e = read_session_csv(&p).unwrap_err().to_string();
        assert!(e.contains("line 3") && e.contains("s.csv"), "{e}");
    }
}
