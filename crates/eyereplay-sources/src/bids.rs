//! BIDS eye tracking (BEP020): a headerless `*_physio.tsv[.gz]` whose columns
//! are named by the `Columns` list of the `*_physio.json` sidecar.
//!
//! Read from the sidecar: `SamplingFrequency`, `StartTime`, `Columns`,
//! optional `ScreenResolution` (px), `ScreenSize` (m) and `ScreenDistance`
//! (m), and a `timestamp` column description with `Units`. Without `Units`
//! the timestamp unit is inferred from the sampling frequency (an interval of
//! 2 at 500 Hz is milliseconds) and checked, never guessed silently.
//! The sidecar may be the file's own or inherited from folders above inside
//! its dataset (BIDS's inheritance principle), the nearer's keys winning.

use crate::series::{parse_f64, ScreenSeries};
use crate::{file_name, ReadOptions, Recording, ScreenOptions, SourceError};
use serde_json::Value;
use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};

pub(crate) fn sidecar_path(path: &Path) -> PathBuf {
    let s = path.to_string_lossy();
    PathBuf::from(format!("{}.json", data_stem(&s)))
}

/// The name without `.tsv` or `.tsv.gz`.
fn data_stem(name: &str) -> &str {
    name.strip_suffix(".tsv.gz")
        .or_else(|| name.strip_suffix(".tsv"))
        .unwrap_or(name)
}

/// A BIDS name's entities (`sub-01`, `task-reading`, ...) and its suffix
/// (`physio`): `sub-01_task-reading_physio` gives
/// `[("sub", "01"), ("task", "reading")]` and `physio`.
fn entities(stem: &str) -> (Vec<(&str, &str)>, &str) {
    let mut parts: Vec<&str> = stem.split('_').collect();
    let suffix = parts.pop().unwrap_or("");
    let pairs = parts.iter().filter_map(|p| p.split_once('-')).collect();
    (pairs, suffix)
}

/// The folders whose sidecars apply to `path`, the dataset's root first.
/// BIDS's inheritance principle: a sidecar in a folder above, such as
/// `task-reading_physio.json` at the root, applies to every data file
/// below whose name holds its entities. Walked only inside a dataset (a
/// folder above, at most three up, holds `dataset_description.json`), so
/// that a loose file never picks up JSON from unrelated folders.
fn sidecar_folders(path: &Path) -> Vec<PathBuf> {
    let own = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    // Absolute, so that the folders above a relative path (`sub-01/beh`
    // from the dataset's root) are reached: `Path::parent` of a relative
    // path stops at "".
    let own = std::fs::canonicalize(&own).unwrap_or(own);
    let chain: Vec<PathBuf> = own.ancestors().take(4).map(Path::to_path_buf).collect();
    match chain
        .iter()
        .position(|d| d.join("dataset_description.json").is_file())
    {
        Some(root) => chain[..=root].iter().rev().cloned().collect(),
        None => vec![own],
    }
}

/// The sidecar metadata of `path`: every `*_physio.json` that applies to
/// it (its own, beside it, and those it inherits), the nearer's keys over
/// the farther's, and the path of the nearest, which errors about the
/// metadata name.
fn read_sidecar(path: &Path) -> Result<(PathBuf, Value), SourceError> {
    let own_stem = data_stem(&file_name(path)).to_string();
    let (own_entities, own_suffix) = entities(&own_stem);
    let mut merged = serde_json::Map::new();
    let mut nearest: Option<PathBuf> = None;
    for dir in sidecar_folders(path) {
        let Ok(listing) = std::fs::read_dir(&dir) else {
            continue;
        };
        // Fewer entities first: the more specific sidecar of a folder
        // overrides the more general.
        let mut applying: Vec<(usize, PathBuf)> = listing
            .flatten()
            .filter_map(|e| {
                let name = e.file_name().to_string_lossy().into_owned();
                let stem = name.strip_suffix(".json")?;
                let (ents, suffix) = entities(stem);
                let applies = suffix == own_suffix
                    && ents.iter().all(|kv| own_entities.contains(kv))
                    && (stem == own_stem || stem.split('_').count() == ents.len() + 1);
                applies.then(|| (ents.len(), e.path()))
            })
            .collect();
        applying.sort();
        for (_, side_path) in applying {
            let text = std::fs::read_to_string(&side_path).map_err(|e| {
                SourceError::file(
                    &side_path,
                    format!("BIDS sidecar for {} unreadable: {e}", file_name(path)),
                )
            })?;
            let value: Value = serde_json::from_str(&text)
                .map_err(|e| SourceError::file(&side_path, format!("invalid JSON: {e}")))?;
            let Value::Object(fields) = value else {
                return Err(SourceError::file(
                    &side_path,
                    "not a JSON object (a BIDS sidecar holds {\"SamplingFrequency\": ..., ...})",
                ));
            };
            merged.extend(fields);
            nearest = Some(side_path);
        }
    }
    let nearest = nearest.ok_or_else(|| {
        SourceError::file(
            sidecar_path(path),
            format!(
                "BIDS sidecar for {} missing: no {} beside it, nor one it inherits \
                 from a folder above inside its dataset",
                file_name(path),
                file_name(&sidecar_path(path))
            ),
        )
    })?;
    Ok((nearest, Value::Object(merged)))
}

pub(crate) fn read(
    path: &Path,
    screen: &ScreenOptions,
    opts: &ReadOptions,
) -> Result<Recording, SourceError> {
    let (side_path, side) = read_sidecar(path)?;
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
    // The config's geometry, where it gives one, outranks the sidecar's, as
    // `screen_px` outranks `ScreenResolution`: a config that sets
    // `screen_width_mm` or `distance_mm` (not only `px_per_deg`) is one
    // written because the sidecar's are wrong or missing. Left at the
    // defaults, the sidecar's values are used.
    let mut geometry = screen.geometry;
    if geometry == crate::ViewingGeometry::default() {
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
        let missing = crate::series::is_missing;
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
