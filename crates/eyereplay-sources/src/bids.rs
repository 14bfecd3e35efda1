//! BIDS eye tracking (BEP020): a headerless `*_physio.tsv[.gz]` whose columns
//! are named by the `Columns` list of the `*_physio.json` sidecar.
//!
//! Read from the sidecar: `SamplingFrequency`, `StartTime`, `Columns`,
//! optional `ScreenResolution` (px), `ScreenSize` (m) and `ScreenDistance`
//! (m), and a `timestamp` column description with `Units`. Without `Units`
//! the timestamp unit is inferred from the sampling frequency (an interval of
//! 2 at 500 Hz is milliseconds) and checked, never guessed silently.

use crate::series::{parse_f64, ScreenSeries};
use crate::{file_name, ReadOptions, Recording, ScreenOptions, SourceError};
use serde_json::Value;
use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};

pub(crate) fn sidecar_path(path: &Path) -> PathBuf {
    let s = path.to_string_lossy();
    let stem = s
        .strip_suffix(".tsv.gz")
        .or_else(|| s.strip_suffix(".tsv"))
        .unwrap_or(&s);
    PathBuf::from(format!("{stem}.json"))
}

pub(crate) fn read(
    path: &Path,
    screen: &ScreenOptions,
    opts: &ReadOptions,
) -> Result<Recording, SourceError> {
    let side_path = sidecar_path(path);
    let side_text = std::fs::read_to_string(&side_path).map_err(|e| {
        SourceError::file(
            &side_path,
            format!("BIDS sidecar for {} unreadable: {e}", file_name(path)),
        )
    })?;
    let side: Value = serde_json::from_str(&side_text)
        .map_err(|e| SourceError::file(&side_path, format!("invalid JSON: {e}")))?;
    let fs = side
        .get("SamplingFrequency")
        .and_then(Value::as_f64)
        .filter(|f| *f > 0.0)
        .ok_or_else(|| {
            SourceError::file(
                &side_path,
                "SamplingFrequency missing or not a positive number",
            )
        })?;
    let start_s = side.get("StartTime").and_then(Value::as_f64).unwrap_or(0.0);
    let columns: Vec<String> = side
        .get("Columns")
        .and_then(Value::as_array)
        .ok_or_else(|| SourceError::file(&side_path, "Columns missing (list of column names)"))?
        .iter()
        .map(|v| v.as_str().unwrap_or("").to_string())
        .collect();
    let col = |name: &str| columns.iter().position(|c| c == name);
    let (xi, yi) = match (col("x_coordinate"), col("y_coordinate")) {
        (Some(x), Some(y)) => (x, y),
        _ => {
            return Err(SourceError::file(
                &side_path,
                format!(
                    "Columns lacks x_coordinate / y_coordinate: {}",
                    columns.join(",")
                ),
            ))
        }
    };
    let ti = col("timestamp");
    let declared_unit = side
        .get("timestamp")
        .and_then(|d| d.get("Units"))
        .and_then(Value::as_str)
        .map(str::to_string);

    let screen_px = screen
        .screen_px
        .or_else(|| {
            let r = side.get("ScreenResolution")?.as_array()?;
            Some([r.first()?.as_f64()?, r.get(1)?.as_f64()?])
        })
        .ok_or_else(|| {
            SourceError::file(
                &side_path,
                "no ScreenResolution; give screen_px = [width, height]",
            )
        })?;
    let mut geometry = screen.geometry;
    if geometry.px_per_deg.is_none() {
        if let (Some(size), Some(dist)) = (
            side.get("ScreenSize").and_then(Value::as_array),
            side.get("ScreenDistance").and_then(Value::as_f64),
        ) {
            if let Some(w_m) = size.first().and_then(Value::as_f64) {
                geometry.screen_width_mm = w_m * 1e3;
                geometry.distance_mm = dist * 1e3;
            }
        }
    }
    let ppd = geometry.px_per_deg(screen_px[0]);

    let file = std::fs::File::open(path).map_err(|e| SourceError::io(path, e))?;
    let reader: Box<dyn Read> = if path.to_string_lossy().ends_with(".gz") {
        Box::new(flate2::read::MultiGzDecoder::new(file))
    } else {
        Box::new(file)
    };
    let mut rows: Vec<(u64, f64, Option<[f64; 2]>)> = Vec::new();
    for (i, line) in BufReader::new(reader).lines().enumerate() {
        let line_no = i as u64 + 1;
        let line = line.map_err(|e| SourceError::file(path, format!("line {line_no}: {e}")))?;
        if line.trim().is_empty() {
            continue;
        }
        let cells: Vec<&str> = line.split('\t').collect();
        if cells.len() != columns.len() {
            return Err(SourceError::line(
                path,
                line_no,
                format!(
                    "{} columns, sidecar Columns names {}",
                    cells.len(),
                    columns.len()
                ),
            ));
        }
        let t = match ti {
            Some(k) => parse_f64(path, line_no, "timestamp", cells[k])?,
            None => start_s + rows.len() as f64 / fs,
        };
        let missing = |c: &str| matches!(c.trim(), "n/a" | "" | "NaN" | "nan");
        let g = if missing(cells[xi]) || missing(cells[yi]) {
            None
        } else {
            Some([
                parse_f64(path, line_no, "x_coordinate", cells[xi])?,
                parse_f64(path, line_no, "y_coordinate", cells[yi])?,
            ])
        };
        rows.push((line_no, t, g));
    }
    if rows.len() < 2 {
        return Err(SourceError::file(path, "fewer than 2 samples"));
    }
    let to_s = match ti {
        None => 1.0,
        Some(_) => timestamp_scale(path, declared_unit.as_deref(), &rows, fs)?,
    };
    let mut series = ScreenSeries::new(path, screen_px, ppd, opts)?;
    for (line, t, g) in rows {
        series.push(line, t * to_s, g, false)?;
    }
    series.finish()
}

/// Seconds per timestamp unit: declared, or inferred from the sampling
/// frequency and rejected when neither s, ms nor us fits.
fn timestamp_scale(
    path: &Path,
    declared: Option<&str>,
    rows: &[(u64, f64, Option<[f64; 2]>)],
    fs: f64,
) -> Result<f64, SourceError> {
    match declared {
        Some("s") => return Ok(1.0),
        Some("ms") => return Ok(1e-3),
        Some("us") | Some("µs") => return Ok(1e-6),
        Some(other) => {
            return Err(SourceError::file(
                path,
                format!(
                    "timestamp Units {} not understood (s, ms, us)",
                    crate::error::cell(other)
                ),
            ))
        }
        None => {}
    }
    let mut dts: Vec<f64> = rows.windows(2).map(|w| w[1].1 - w[0].1).collect();
    let mid = dts.len() / 2;
    let dt = *dts.select_nth_unstable_by(mid, |a, b| a.total_cmp(b)).1;
    let ratio = dt * fs;
    for (unit_per_s, s_per_unit) in [(1.0, 1.0), (1e3, 1e-3), (1e6, 1e-6)] {
        if (ratio / unit_per_s - 1.0).abs() < 0.2 {
            return Ok(s_per_unit);
        }
    }
    Err(SourceError::file(
        path,
        format!("timestamps step by {dt} at SamplingFrequency {fs} Hz: neither s, ms nor us; declare timestamp Units in the sidecar"),
    ))
}
