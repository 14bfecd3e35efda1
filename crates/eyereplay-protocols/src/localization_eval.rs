//! When does someone read? The localization protocol (`eyereplay
//! evaluate-localization`): on sessions whose per-frame `reading` column
//! is known (behaviour models' interview scenarios), each way of turning
//! window scores into frames ([`eyereplay_detect::localize::Method`]) finds
//! reading segments, and they are matched to the true ones: segment F1 at
//! IoU 0.5, onset error, and the share of not-reading time called reading.

use eyereplay::{Error, Result};
use eyereplay_detect::localize::{self, match_segments, Method, SegmentMatch};
use eyereplay_detect::{DetectorModel, FPS};
use serde::Serialize;
use std::path::Path;

/// Segments of at least this IoU with a true one count as found.
pub const MIN_IOU: f64 = 0.5;

/// One method's results over every session.
#[derive(Clone, Debug, Serialize)]
pub struct MethodResult {
    pub method: Method,
    /// Pooled over sessions (each session matched on its own).
    pub segments: SegmentMatch,
    pub onset_error_median_s: Option<f64>,
    /// Frames called reading among the frames that are not reading.
    pub false_reading_fraction: f64,
    /// Frames called reading among the frames that are reading.
    pub reading_recall: f64,
}

/// What [`evaluate_localization`] measured.
#[derive(Clone, Debug, Serialize)]
pub struct LocalizationEval {
    pub dataset: String,
    pub model: String,
    /// Where segments are cut.
    pub threshold: f64,
    pub sessions: usize,
    pub reading_segments: usize,
    pub seconds: f64,
    pub methods: Vec<MethodResult>,
}

/// Runs of `true` in `flags`, as `(start_s, end_s)` at [`FPS`].
pub fn true_runs(flags: &[bool]) -> Vec<(f64, f64)> {
    localize::runs(flags.iter().copied())
        .into_iter()
        .map(|(a, b)| (a as f64 / FPS, b as f64 / FPS))
        .collect()
}

/// Every session of the dataset in `dir` that has a `reading` column, read
/// as its trajectory, localized by each method with the detector in
/// `model_path`.
pub fn evaluate_localization(
    dir: &Path,
    model_path: &Path,
    threshold: f64,
) -> Result<LocalizationEval> {
    let model = DetectorModel::load(model_path)?;
    let labels = eyereplay_dataset::read_labels(dir)?;
    let mut truth_runs = Vec::new();
    let mut tracks = Vec::new();
    let mut flags_all = Vec::new();
    for l in &labels {
        let paths = eyereplay_dataset::SessionPaths::new(dir, &l.file)
            .map_err(|e| Error::input(dir.join("labels.csv"), e.to_string()))?;
        let Some(flags) = eyereplay_dataset::read_reading_column(&paths.csv)? else {
            continue;
        };
        tracks.push(eyereplay::detector::session_csv_track(&paths.csv)?);
        truth_runs.push(true_runs(&flags));
        flags_all.push(flags);
    }
    if tracks.is_empty() {
        return Err(Error::input(
            dir,
            "no session has a per-frame reading column (generate interview sessions: model = \"interview\")",
        ));
    }
    let mut methods = Vec::new();
    for method in [Method::WindowMean, Method::Hmm] {
        let (mut found_n, mut truth_n, mut onsets) = (0, 0, Vec::new());
        let (mut fp, mut neg, mut tp, mut pos) = (0usize, 0usize, 0usize, 0usize);
        for ((track, truth), flags) in tracks.iter().zip(&truth_runs).zip(&flags_all) {
            let loc = localize::localize(track, &model, method, threshold);
            let found: Vec<(f64, f64)> =
                loc.segments.iter().map(|s| (s.start_s, s.end_s)).collect();
            let m = match_segments(&found, truth, MIN_IOU);
            found_n += m.found;
            truth_n += m.truth;
            onsets.extend(m.onset_errors_s);
            for (k, &f) in flags.iter().enumerate() {
                let t = k as f64 / FPS;
                let called = found.iter().any(|&(a, b)| a <= t && t < b);
                match f {
                    true => {
                        pos += 1;
                        tp += called as usize;
                    }
                    false => {
                        neg += 1;
                        fp += called as usize;
                    }
                }
            }
        }
        let pooled = SegmentMatch::from_counts(found_n, truth_n, onsets);
        let ratio = |m: usize, n: usize| if n == 0 { 1.0 } else { m as f64 / n as f64 };
        let onset_error_median_s = eyereplay_signal::stats::median(&pooled.onset_errors_s);
        methods.push(MethodResult {
            method,
            segments: pooled,
            onset_error_median_s,
            false_reading_fraction: ratio(fp, neg),
            reading_recall: ratio(tp, pos),
        });
    }
    Ok(LocalizationEval {
        dataset: dir.display().to_string(),
        model: model_path.display().to_string(),
        threshold,
        sessions: tracks.len(),
        reading_segments: truth_runs.iter().map(Vec::len).sum(),
        seconds: tracks.iter().map(|t| t.duration_s()).sum(),
        methods,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn runs_of_flags_in_seconds() {
        let f = |s: &str| s.chars().map(|c| c == '1').collect::<Vec<_>>();
        // At 25 fps: frames 25..50 and 75..100 (the end).
        let flags = f(&("0".repeat(25) + &"1".repeat(25) + &"0".repeat(25) + &"1".repeat(25)));
        assert_eq!(true_runs(&flags), [(1.0, 2.0), (3.0, 4.0)]);
        assert!(true_runs(&f("000")).is_empty());
    }
}
