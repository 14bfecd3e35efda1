//! Generic eye-tracker samples in a CSV or TSV table, and the table helpers
//! the other delimited-text readers share.

use crate::series::{for_each_record, parse_f64, ScreenSeries};
use crate::{ReadOptions, Recording, SourceError, TimeUnit, ViewingGeometry};
use std::path::Path;

pub(crate) struct Columns<'a> {
    pub time: Option<&'a str>,
    pub x: Option<&'a str>,
    pub y: Option<&'a str>,
}

const TIME_NAMES: &[&str] = &["time", "timestamp", "t", "time_ms"];
const X_NAMES: &[&str] = &["x", "x_px", "pixel_x", "x_pix", "gaze_x"];
const Y_NAMES: &[&str] = &["y", "y_px", "pixel_y", "y_pix", "gaze_y"];

pub(crate) fn read(
    path: &Path,
    cols: Columns<'_>,
    time_unit: TimeUnit,
    screen_px: [f64; 2],
    geometry: &ViewingGeometry,
    opts: &ReadOptions,
) -> Result<Recording, SourceError> {
    let delim = if path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("tsv"))
    {
        b'\t'
    } else {
        b','
    };
    let (headers, mut rdr) = open_table(path, delim)?;
    let find = |given: Option<&str>, defaults: &[&str], what: &str| -> Result<usize, SourceError> {
        let names: Vec<&str> = match given {
            Some(g) => vec![g],
            None => defaults.to_vec(),
        };
        column_index(&headers, &names).ok_or_else(|| {
            // A header read as one column that holds another separator:
            // the file is not separated as its name says, and the names
            // looked for are in it.
            let other = [('\t', "tabs"), (';', "semicolons"), (',', "commas")]
                .into_iter()
                .find(|(c, _)| *c != delim as char && headers.len() == 1 && headers[0].contains(*c));
            let message = match other {
                Some((_, by)) => format!(
                    "its header reads as one column, separated by {by} ({}); a .csv is read comma-separated, \
                     a .tsv tab-separated: name the file for its separator, or convert it",
                    headers[0].replace('\t', "\\t")
                ),
                None => format!(
                    "no {what} column (looked for {}; header: {}); name it with {what}_column",
                    names.join(" or "),
                    headers.join(",")
                ),
            };
            SourceError::file(path, message)
        })
    };
    let ti = find(cols.time, TIME_NAMES, "time")?;
    let xi = find(cols.x, X_NAMES, "x")?;
    let yi = find(cols.y, Y_NAMES, "y")?;
    let ppd = geometry.px_per_deg(screen_px[0]);

    let mut series = ScreenSeries::new(path, screen_px, ppd, opts)?;
    for_each_record(path, &mut rdr, |rec, line| {
        let t = parse_f64(path, line, &headers[ti], rec.get(ti).unwrap_or(""))?;
        // Empty, NaN or NA coordinates are tracking loss, not a format error.
        let coord = |i: usize| -> Result<Option<f64>, SourceError> {
            let c = rec.get(i).unwrap_or("").trim();
            if crate::series::is_missing(c) {
                Ok(None)
            } else {
                parse_f64(path, line, &headers[i], c).map(Some)
            }
        };
        let gaze = match (coord(xi)?, coord(yi)?) {
            (Some(x), Some(y)) => Some([x, y]),
            _ => None,
        };
        series.push(line, time_unit.to_seconds(t), gaze, false)
    })?;
    series.finish()
}

/// Opens a delimited table with a header row; an empty file or a file
/// without a header is an error naming the file.
pub(crate) fn open_table(
    path: &Path,
    delim: u8,
) -> Result<(Vec<String>, csv::Reader<std::fs::File>), SourceError> {
    let file = std::fs::File::open(path).map_err(|e| SourceError::io(path, e))?;
    let mut rdr = csv::ReaderBuilder::new()
        .delimiter(delim)
        .flexible(true)
        .from_reader(file);
    let headers: Vec<String> = rdr
        .headers()
        .map_err(|e| SourceError::file(path, e.to_string()))?
        .iter()
        .map(|h| h.trim().to_string())
        .collect();
    if headers.iter().all(|h| h.is_empty()) {
        return Err(SourceError::file(path, "empty file (no header row)"));
    }
    Ok((headers, rdr))
}

/// Index of the first of `names` present in `headers` (case-insensitive).
pub(crate) fn column_index(headers: &[String], names: &[&str]) -> Option<usize> {
    names
        .iter()
        .find_map(|n| headers.iter().position(|h| h.eq_ignore_ascii_case(n)))
}
