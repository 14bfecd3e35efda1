//! Reading a rendered video back: what `eyereplay evaluate` compares with
//! the trajectory it was drawn from, what the full-face mode's
//! `match_readback` fits, and what the detector reads from a close-up.
//! The same extractor as `eyereplay extract`, so a read-back measures the
//! video as a user's extraction would.

use crate::{
    extract_many, order_eye_corners, CornerReference, ExtractError, ExtractOptions, EyeCropTracker,
    Models, Pt, Result, Row, DEFAULT_BLINK_RATIO,
};
use std::path::Path;

/// Frames each side of a flagged blink whose lids are still part-closed.
pub const BLINK_MARGIN_FRAMES: usize = 2;

/// Closed-eye flags widened by [`BLINK_MARGIN_FRAMES`] each side: the
/// frames a read-back is not compared on (the evaluation) or fitted to
/// (the full-face mode's `match_readback`).
pub fn widen_blinks(flagged: &[bool]) -> Vec<bool> {
    let n = flagged.len();
    let mut closed = flagged.to_vec();
    for (i, _) in flagged.iter().enumerate().filter(|(_, &b)| b) {
        for c in
            &mut closed[i.saturating_sub(BLINK_MARGIN_FRAMES)..(i + BLINK_MARGIN_FRAMES + 1).min(n)]
        {
            *c = true;
        }
    }
    closed
}

/// A row's mean `(nx, ny)` over both eyes, NaN where the row is not valid
/// (no face, or a blink).
pub fn row_norm(r: &Row) -> [f64; 2] {
    match r.mean_n() {
        Some((x, y)) if r.valid() => [x, y],
        _ => [f64::NAN, f64::NAN],
    }
}

/// The extractor's rows for the first `n_max` frames by its full pipeline,
/// each eye read from `iris_views` crops.
pub fn extract_with_detector(
    video: &Path,
    models: &Path,
    n_max: usize,
    fps: f64,
    iris_views: usize,
    progress: &dyn crate::Progress,
) -> Result<Vec<Row>> {
    let opts = ExtractOptions {
        models_dir: models.to_path_buf(),
        iris_views,
        max_duration_s: Some(n_max as f64 / fps),
        ..Default::default()
    };
    let ext = extract_many(&[video.to_path_buf()], &opts, progress)
        .pop()
        .expect("one result per video")
        .map_err(|e| ExtractError::ReadBack {
            path: video.to_path_buf(),
            message: format!("extracting the iris: {e}"),
        })?;
    let mut rows = ext.rows;
    rows.truncate(n_max);
    Ok(rows)
}

/// The extractor's iris step without face detection ([`EyeCropTracker`]):
/// the iris model on eye crops placed at the render's known corners as
/// MediaPipe places them; `nx` against those fixed corners (camera and head
/// do not move in a close-up render), `ny` against the model's lids; blinks
/// by the extractor's aperture rule are NaN.
pub fn extract_at_corners(
    video: &Path,
    models: &Path,
    corners: [([f64; 2], [f64; 2]); 2],
    n_max: usize,
    iris_views: usize,
) -> Result<Vec<[f64; 2]>> {
    let pt = |p: [f64; 2]| Pt::new(p[0] as f32, p[1] as f32);
    // Image-left eye first, each pair left to right, as the crops expect.
    let corners = order_eye_corners(corners.map(|(a, b)| (pt(a), pt(b))));
    let m = Models::load(models)?;
    let mut tracker = EyeCropTracker::new(m);
    tracker.iris_views = iris_views;
    let rows = tracker
        .measure_video_rows(
            video,
            &corners,
            CornerReference::Fixed,
            Some(n_max),
            DEFAULT_BLINK_RATIO,
        )
        .map_err(|e| ExtractError::ReadBack {
            path: video.to_path_buf(),
            message: format!("measuring the eyes: {e}"),
        })?;
    Ok(rows.iter().map(row_norm).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blinks_widen_by_two_frames_each_side_and_stop_at_the_ends() {
        let flags: Vec<bool> = (0..10).map(|i| i == 5 || i == 0).collect();
        let want: Vec<bool> = (0..10).map(|i| (3..=7).contains(&i) || i <= 2).collect();
        assert_eq!(widen_blinks(&flags), want);
    }
}
