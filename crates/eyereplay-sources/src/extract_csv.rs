//! `eyereplay extract` output: `frame,time_s,valid,nx,ny,...` with optional
//! `blink` and per-eye apertures. Columns are found by name, so columns the
//! extractor adds later do not break this reader.

use crate::samples_csv::{column_index, open_table};
use crate::series::{for_each_record, parse_f64, recording, SeriesBuilder};
use crate::{file_name, ReadOptions, Recording, RecordingKind, SourceError};
use eyereplay_core::{NormPos, Sample};
use std::path::Path;

pub(crate) fn read(path: &Path, opts: &ReadOptions) -> Result<Recording, SourceError> {
    let (headers, mut rdr) = open_table(path, b',')?;
    let need = |name: &str| {
        column_index(&headers, &[name]).ok_or_else(|| {
            SourceError::file(
                path,
                format!(
                    "missing column '{name}': not an 'eyereplay extract' CSV (header: {})",
                    headers.join(",")
                ),
            )
        })
    };
    let (ti, vi, xi, yi) = (need("time_s")?, need("valid")?, need("nx")?, need("ny")?);
    let bi = column_index(&headers, &["blink"]);
    let ai = column_index(&headers, &["aperture"]);
    let al = column_index(&headers, &["aperture_left"]);
    let ar = column_index(&headers, &["aperture_right"]);

    let mut series = SeriesBuilder::<NormPos>::new(path);
    for_each_record(path, &mut rdr, |rec, line| {
        let flag = |i: usize, name: &str| -> Result<bool, SourceError> {
            match rec.get(i).unwrap_or("").trim() {
                "1" | "true" => Ok(true),
                "0" | "false" | "" => Ok(false),
                other => Err(SourceError::line(
                    path,
                    line,
                    format!(
                        "column '{name}': {} is not 0 or 1",
                        crate::error::cell(other)
                    ),
                )),
            }
        };
        let t_s = parse_f64(path, line, "time_s", rec.get(ti).unwrap_or(""))?;
        let valid = flag(vi, "valid")?;
        let blink = match bi {
            Some(i) => flag(i, "blink")?,
            None => false,
        };
        // An invalid frame may carry empty or NaN positions: keep it as a
        // placeholder that the blink filter will fill.
        let num = |i: usize, name: &str| -> Result<f64, SourceError> {
            let c = rec.get(i).unwrap_or("").trim();
            if !valid && (c.is_empty() || c.eq_ignore_ascii_case("nan")) {
                Ok(f64::NAN)
            } else {
                parse_f64(path, line, name, c)
            }
        };
        let nx = num(xi, "nx")?;
        let ny = num(yi, "ny")?;
        let opt = |i: Option<usize>| -> Option<f64> {
            i.and_then(|i| rec.get(i))
                .and_then(|c| c.trim().parse::<f64>().ok())
                .filter(|v| v.is_finite())
        };
        let aperture = opt(ai).or_else(|| match (opt(al), opt(ar)) {
            (Some(a), Some(b)) => Some(0.5 * (a + b)),
            (a, b) => a.or(b),
        });
        series.push(
            line,
            Sample {
                t_s,
                pos: NormPos { nx, ny },
                valid: valid && nx.is_finite() && ny.is_finite(),
                aperture,
                blink,
            },
        )?;
        Ok(())
    })?;
    let segments = series.finish(opts.max_gap_s)?;
    recording(path, file_name(path), RecordingKind::Video, segments, None)
}
