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

/// Writes `frame,x,y,blink` rows atomically (`blink` 1 where the source
/// blinked), for datasets whose sources mark blinks; `blinks` has one flag
/// per point. The renderer closes the lids there.
pub fn write_session_csv_with_blinks(
    path: &Path,
    points: &[CanvasPos],
    blinks: &[bool],
) -> Result<(), CoreError> {
    write_session_csv_columns(path, points, Some(blinks), None)
}

/// Writes `frame,x,y` rows atomically. Coordinates are written with 3
/// decimals (1/1000 px), which keeps files small and byte-identical across
/// runs.
pub fn write_session_csv(path: &Path, points: &[CanvasPos]) -> Result<(), CoreError> {
    write_session_csv_columns(path, points, None, None)
}

/// Writes `frame,x,y[,blink][,reading]` rows atomically: the optional
/// columns are there when given, one flag per point, written 1/0. `reading`
/// is the per-frame label of a dataset with behaviour models (1 where the
/// person reads).
pub fn write_session_csv_columns(
    path: &Path,
    points: &[CanvasPos],
    blinks: Option<&[bool]>,
    reading: Option<&[bool]>,
) -> Result<(), CoreError> {
    let flags: Vec<(&str, &[bool])> = [("blink", blinks), ("reading", reading)]
        .into_iter()
        .filter_map(|(name, f)| f.map(|f| (name, f)))
        .collect();
    for (name, f) in &flags {
        assert_eq!(points.len(), f.len(), "one {name} flag per point");
    }
    atomic_write_with(path, |w| {
        w.write_all(b"frame,x,y")?;
        for (name, _) in &flags {
            w.write_all(b",")?;
            w.write_all(name.as_bytes())?;
        }
        w.write_all(b"\n")?;
        let mut line = Vec::with_capacity(48);
        for (i, p) in points.iter().enumerate() {
            line.clear();
            push_point_row(&mut line, i as u64, *p);
            for (_, f) in &flags {
                line.extend_from_slice(if f[i] { b",1" } else { b",0" });
            }
            line.push(b'\n');
            w.write_all(&line)?;
        }
        Ok(())
    })
}

/// Appends `frame,x,y` (3 decimals, no newline): the row of every
/// canvas-trajectory CSV eyereplay writes.
pub fn push_point_row(out: &mut Vec<u8>, frame: u64, p: CanvasPos) {
    push_u64(out, frame);
    out.push(b',');
    push_fixed3(out, p.x_px);
    out.push(b',');
    push_fixed3(out, p.y_px);
}

/// Appends an unsigned integer in decimal.
pub fn push_u64(out: &mut Vec<u8>, mut v: u64) {
    let mut buf = [0u8; 20];
    let mut i = buf.len();
    loop {
        i -= 1;
        buf[i] = b'0' + (v % 10) as u8;
        v /= 10;
        if v == 0 {
            break;
        }
    }
    out.extend_from_slice(&buf[i..]);
}

/// Appends `v` with exactly 3 decimals, the same text as `format!("{v:.3}")`
/// for finite values below 2^53 / 1000 in magnitude, about 20 times faster
/// (float formatting dominated writing a dataset). Ties round half to even
/// like `format!`, since both round the exact binary value.
pub fn push_fixed3(out: &mut Vec<u8>, v: f64) {
    if !v.is_finite() || v.abs() >= 9.0e12 {
        out.extend_from_slice(format!("{v:.3}").as_bytes());
        return;
    }
    // Scaling by 1000 can round; decide ties and near-ties with format!.
    let scaled = v.abs() * 1000.0;
    let frac = scaled - scaled.floor();
    if (frac - 0.5).abs() < 1e-6 {
        out.extend_from_slice(format!("{v:.3}").as_bytes());
        return;
    }
    let m = scaled.round() as u64;
    // `format!` keeps the sign of values that round to zero ("-0.000").
    if v.is_sign_negative() {
        out.push(b'-');
    }
    push_u64(out, m / 1000);
    out.push(b'.');
    let f = m % 1000;
    out.push(b'0' + (f / 100) as u8);
    out.push(b'0' + (f / 10 % 10) as u8);
    out.push(b'0' + (f % 10) as u8);
}

/// The largest canvas coordinate a session CSV may hold, in px: far off
/// any canvas (1280x720 by default), far from overflowing a speed.
pub const MAX_CANVAS_COORD_PX: f64 = 1e6;

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
        // Finite but absurd (1e308): speeds and plot axes overflowed to
        // infinity, and the report's log axis looped for ever.
        if let Some((name, v)) = [("x", row.x), ("y", row.y)]
            .into_iter()
            .find(|(_, v)| v.abs() > MAX_CANVAS_COORD_PX)
        {
            return Err(CoreError::Parse {
                path: path.into(),
                line,
                message: format!(
                    "{name} = {v:e} px is not a canvas position (at most {MAX_CANVAS_COORD_PX:e} either way)"
                ),
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
        // A video or an image given where a CSV goes.
        csv::ErrorKind::Utf8 { .. } => {
            "not text (a video or other binary file?); a session CSV has the header frame,x,y"
                .to_string()
        }
        _ => e.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fixed3_matches_format() {
        let mut seed = 1u64;
        let mut vals = vec![
            0.0, -0.0, 0.0004, -0.0004, 0.0005, 0.0015, 1.2345, -1.2345, 639.9995, 1280.0, -3.5e-7,
            123456.789,
        ];
        for _ in 0..20000 {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let u = (seed >> 11) as f64 / (1u64 << 53) as f64;
            vals.push((u - 0.3) * 3000.0);
            vals.push(((u * 1e6).round()) / 1000.0 + 0.0005);
        }
        for v in vals {
            let mut b = Vec::new();
            push_fixed3(&mut b, v);
            assert_eq!(String::from_utf8(b).unwrap(), format!("{v:.3}"), "{v:e}");
        }
    }

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

        // Finite but far off any canvas: refused with its line.
        std::fs::write(&p, "frame,x,y\n0,1,2\n1,1e308,3\n").unwrap();
        let e = read_session_csv(&p).unwrap_err().to_string();
        assert!(
            e.contains("line 3") && e.contains("not a canvas position"),
            "{e}"
        );
        std::fs::write(&p, "frame,x,y\n0,-2000,5000\n").unwrap();
        assert_eq!(read_session_csv(&p).unwrap()[0].x_px, -2000.0);
    }
}
