//! Clips too short or too patchy for one whole window (3-10 s of gaze, a
//! laugh, a look down): scored from what they have, with an interval that
//! says how far to trust it, or refused with how much gaze there is and
//! how much is needed. Never a silent guess.
//!
//! The score is the model's on one window made of the clip's best stretch:
//! the longest piece, at most one window long, with gaze in at least
//! `1 -` [`MAX_MISSING_FRACTION`] of its frames. A short window's features
//! are noisier than a whole window's; the interval measures that on the
//! clip itself: every sub-stretch of [`SUB_FRACTION`] of it, [`SUB_STEP`]
//! frames apart, is scored the same way, and the 5th and 95th percentiles
//! of those scores (widened to hold the clip's own) are the interval: how
//! far the score moves with which part of the behaviour the clip caught.
//! A moving-block bootstrap of the gaze steps was tried first and
//! rejected: joining blocks makes jumps and drift a real track lacks, and
//! its intervals were so wide that most 6-s clips came out uncertain
//! although the model was right on 99 % of them (docs/DETECTOR.md).

use crate::model::DetectorModel;
use crate::window::{prepare_window, Track, FPS, MAX_MISSING_FRACTION};
use serde::{Deserialize, Serialize};

/// The least gaze a clip is scored from.
pub const MIN_CLIP_S: f64 = 3.0;

/// Length of the sub-stretches behind the interval, as a share of the
/// scored stretch.
pub const SUB_FRACTION: f64 = 0.75;

/// Frames between the starts of two sub-stretches.
pub const SUB_STEP: usize = 2;

/// The interval's coverage: from the 5th to the 95th percentile.
pub const INTERVAL_LEVEL: f64 = 0.9;

/// A short clip's score.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ClipScore {
    /// The stretch scored, in the track's seconds.
    pub start_s: f64,
    pub end_s: f64,
    /// Seconds with gaze in that stretch.
    pub usable_s: f64,
    pub reading_probability: f64,
    /// The [`INTERVAL_LEVEL`] interval of the probability over the
    /// stretch's sub-stretches.
    pub low: f64,
    pub high: f64,
    pub level: f64,
}

/// Why a clip could not be scored: its gaze in seconds, and what it needs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NotEnoughGaze {
    pub usable_s: f64,
    pub needed_s: f64,
}

/// Scores the best stretch of `track` of at most `model.window_s`, with
/// its interval.
pub fn score_clip(track: &Track, model: &DetectorModel) -> Result<ClipScore, NotEnoughGaze> {
    let gaze: Vec<bool> = track
        .xy
        .iter()
        .map(|p| p[0].is_finite() && p[1].is_finite())
        .collect();
    let usable_all = gaze.iter().filter(|&&g| g).count();
    let refuse = NotEnoughGaze {
        usable_s: usable_all as f64 / FPS,
        needed_s: MIN_CLIP_S,
    };
    let min_frames = (MIN_CLIP_S * FPS).round() as usize;
    let max_frames = ((model.window_s * FPS).round() as usize).min(track.len());
    let (start, len) = best_stretch(&gaze, min_frames, max_frames).ok_or(refuse)?;
    let xy = &track.xy[start..start + len];
    let w = prepare_window(xy, start).ok_or(refuse)?;
    let probability = model.probability(&w);

    // Every stretch of three quarters of the scored one, a tenth of a
    // second apart: how much the score moves with what part of the
    // behaviour the clip happened to catch.
    let sub = ((len as f64 * SUB_FRACTION).round() as usize).max(2);
    let mut scores: Vec<f64> = (0..=len - sub)
        .step_by(SUB_STEP)
        .filter_map(|a| prepare_window(&xy[a..a + sub], start + a))
        .map(|w| model.probability(&w))
        .collect();
    scores.sort_by(f64::total_cmp);
    let pct = |q: f64| eyereplay_signal::stats::quantile(&scores, q).unwrap_or(probability);
    Ok(ClipScore {
        start_s: start as f64 / FPS,
        end_s: (start + len) as f64 / FPS,
        usable_s: gaze[start..start + len].iter().filter(|&&g| g).count() as f64 / FPS,
        reading_probability: probability,
        // The interval always holds the score itself.
        low: pct(0.05).min(probability),
        high: pct(0.95).max(probability),
        level: INTERVAL_LEVEL,
    })
}

/// The longest stretch of `min_frames..=max_frames` frames whose share
/// without gaze is at most [`MAX_MISSING_FRACTION`], the one with the most
/// gaze among those (the earliest on a tie): `(start, len)`.
pub fn best_stretch(gaze: &[bool], min_frames: usize, max_frames: usize) -> Option<(usize, usize)> {
    let mut prefix = vec![0usize; gaze.len() + 1];
    for (i, &g) in gaze.iter().enumerate() {
        prefix[i + 1] = prefix[i] + g as usize;
    }
    let (top, bottom) = (max_frames.min(gaze.len()), min_frames.max(2));
    if top < bottom {
        return None;
    }
    // Half a second shorter at a time (finer steps change little), ending
    // on the shortest allowed.
    let step = (FPS / 2.0) as usize;
    let mut lengths: Vec<usize> = (bottom + 1..=top).rev().step_by(step).collect();
    lengths.push(bottom);
    for len in lengths {
        let mut best: Option<(usize, usize)> = None;
        for start in 0..=gaze.len() - len {
            let have = prefix[start + len] - prefix[start];
            let missing = 1.0 - have as f64 / len as f64;
            if missing <= MAX_MISSING_FRACTION && best.is_none_or(|(_, h)| have > h) {
                best = Some((start, have));
            }
        }
        if let Some((start, _)) = best {
            return Some((start, len));
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A sawtooth gaze track (slow right, fast back) of `n` frames.
    fn saw(n: usize) -> Track {
        Track::new(
            (0..n)
                .map(|i| {
                    [
                        (i % 40) as f64 + 0.3 * ((i * 7) % 5) as f64,
                        (i / 40) as f64,
                    ]
                })
                .collect(),
        )
    }

    #[test]
    fn a_clip_is_scored_as_one_window_of_its_stretch_with_an_interval_around_it() {
        let model = crate::model::toy_model(6.0);
        let t = saw(100); // 4 s: shorter than the 6 s window
        let c = score_clip(&t, &model).unwrap();
        assert_eq!((c.start_s, c.end_s, c.usable_s), (0.0, 4.0, 4.0));
        let direct = model.probability(&prepare_window(&t.xy, 0).unwrap());
        assert_eq!(c.reading_probability, direct);
        assert!(c.low <= direct && direct <= c.high && c.level == INTERVAL_LEVEL);
        // The same clip gives the same interval.
        assert_eq!(score_clip(&t, &model).unwrap(), c);
    }

    #[test]
    fn too_little_gaze_is_refused_with_what_there_is_and_what_is_needed() {
        let model = crate::model::toy_model(6.0);
        let e = score_clip(&saw(50), &model).unwrap_err();
        assert_eq!(
            e,
            NotEnoughGaze {
                usable_s: 2.0,
                needed_s: MIN_CLIP_S
            }
        );
        // 5 s with every other frame lost: 2.5 s of gaze, none scorable.
        let mut t = saw(125);
        for p in t.xy.iter_mut().step_by(2) {
            *p = [f64::NAN, f64::NAN];
        }
        let e = score_clip(&t, &model).unwrap_err();
        assert!((e.usable_s - 2.48).abs() < 1e-9, "{e:?}");
    }

    #[test]
    fn the_best_stretch_is_the_longest_with_enough_gaze() {
        // 10 frames of gaze, 10 without, 30 with: up to 30 frames, the 30
        // with gaze are the stretch.
        let g: Vec<bool> = (0..50).map(|i| !(10..20).contains(&i)).collect();
        assert_eq!(best_stretch(&g, 5, 30), Some((20, 30)));
        // 40 frames: every placement holds 30 with gaze (25 % missing);
        // the earliest wins.
        assert_eq!(best_stretch(&g, 5, 40), Some((0, 40)));
        // Too little gaze anywhere.
        let sparse: Vec<bool> = (0..100).map(|i| i % 3 == 0).collect();
        assert_eq!(best_stretch(&sparse, 10, 100), None);
        assert_eq!(best_stretch(&g, 60, 80), None);
    }
}
