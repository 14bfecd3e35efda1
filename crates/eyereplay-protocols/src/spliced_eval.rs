//! When does a real person read? Localization on real recordings spliced
//! into mixed streams (`eyereplay evaluate-localization --spliced`).
//!
//! No real interview with a known read answer exists in any package, so
//! the streams are built from what does: the detector protocol's real
//! eye-tracker recordings (OneStop readers; free viewing, visual search
//! and saccade tasks of other people), cut into pieces and joined,
//! reading and not reading in turn, so that every switch is also a switch
//! of person and tracker, as in an interview that cuts from talk to a
//! script. The labels are known by construction. Each recording is first
//! put on one scale (its median at 0, its 5-95 % x range 1), as the
//! per-source calibration of a dataset would.
//!
//! Conditions: `clean` (the recordings at 25 fps), `noise_k` (white noise
//! of k times the x range per frame: webcam-like jitter) and, when the
//! detector protocol was run, `rendered` (each recording rendered as a
//! full face and read back by the extractor: the user's path). The real
//! webcam talkers of the protocol are localized whole: every second
//! called reading there is a false one.

use crate::detector_eval::{Protocol, RecordingSpec};
use crate::localization_eval::{
    score_method, true_segments, window_calibration, MethodResult, WindowCalibration,
};
use eyereplay::detector::{dataset_tracks, extract_csv_track, resample_samples, TrainInput};
use eyereplay::{extract_cached, Error, Result};
use eyereplay_core::Progress;
use eyereplay_detect::localize::{self, Method};
use eyereplay_detect::window::{name_seed, with_white_noise};
use eyereplay_detect::{Track, FPS};
use eyereplay_prepare::DatasetConfig;
use rand::{Rng, SeedableRng};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// How the mixed streams are built.
#[derive(Clone, Debug, Serialize)]
pub struct SpliceOptions {
    pub streams: usize,
    /// Length of each stream.
    pub stream_s: f64,
    /// Length of a reading piece, drawn uniformly (a read answer).
    pub reading_s: (f64, f64),
    /// Length of a not-reading piece, drawn uniformly.
    pub other_s: (f64, f64),
    pub seed: u64,
}

impl Default for SpliceOptions {
    fn default() -> Self {
        SpliceOptions {
            streams: 20,
            stream_s: 300.0,
            reading_s: (20.0, 60.0),
            other_s: (30.0, 90.0),
            seed: 1,
        }
    }
}

/// A spliced stream and its per-frame reading labels.
pub type LabeledStream = (Track, Vec<bool>);

/// One piece of a stream: which recording, from where, how long.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Piece {
    pub recording: String,
    pub reading: bool,
    /// Where in the recording the piece starts, as a share of its length
    /// (the same place in its clean and its rendered version).
    pub offset: f64,
    pub frames: usize,
}

/// Plans `opts.streams` streams over the recordings of each class:
/// reading and not reading in turn (the first class drawn), pieces of
/// the drawn lengths from a recording of that class drawn at random, at
/// a random place. Deterministic in `opts.seed`.
pub fn plan_streams(
    readers: &[String],
    others: &[String],
    opts: &SpliceOptions,
) -> Vec<Vec<Piece>> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(opts.seed);
    let total = (opts.stream_s * FPS).round() as usize;
    (0..opts.streams)
        .map(|_| {
            let mut reading = rng.gen_bool(0.5);
            let mut out = Vec::new();
            let mut at = 0;
            while at < total {
                let (pool, (lo, hi)) = if reading {
                    (readers, opts.reading_s)
                } else {
                    (others, opts.other_s)
                };
                let recording = pool[rng.gen_range(0..pool.len())].clone();
                let frames = ((rng.gen_range(lo..=hi) * FPS).round() as usize).min(total - at);
                out.push(Piece {
                    recording,
                    reading,
                    offset: rng.gen_range(0.0..1.0),
                    frames,
                });
                at += frames;
                reading = !reading;
            }
            out
        })
        .collect()
}

/// The stream of `pieces` cut from `tracks` (name, track), with its
/// per-frame reading labels. A piece longer than what follows its offset
/// wraps round to the recording's start.
pub fn splice(pieces: &[Piece], tracks: &[(String, Track)]) -> (Track, Vec<bool>) {
    let mut xy = Vec::new();
    let mut flags = Vec::new();
    for p in pieces {
        let Some((_, t)) = tracks
            .iter()
            .find(|(n, t)| *n == p.recording && !t.is_empty())
        else {
            continue;
        };
        let start = ((p.offset * t.len() as f64) as usize).min(t.len() - 1);
        xy.extend((0..p.frames).map(|k| t.xy[(start + k) % t.len()]));
        flags.extend(std::iter::repeat_n(p.reading, p.frames));
    }
    (Track::new(xy), flags)
}

/// Every planned stream, cut from the named tracks of `set`.
fn build_streams(plan: &[Vec<Piece>], set: &[(String, Track)]) -> Vec<LabeledStream> {
    plan.iter().map(|pieces| splice(pieces, set)).collect()
}

/// `track` with its median at 0 and its 5-95 % x range 1 (y by the same
/// factor): one scale for recordings of different trackers and screens.
pub fn on_one_scale(track: &Track) -> Track {
    let finite = |k: usize| -> Vec<f64> {
        track
            .xy
            .iter()
            .map(|p| p[k])
            .filter(|v| v.is_finite())
            .collect()
    };
    let (xs, ys) = (finite(0), finite(1));
    let (Some(mx), Some(my)) = (
        eyereplay_signal::stats::median(&xs),
        eyereplay_signal::stats::median(&ys),
    ) else {
        return track.clone();
    };
    let range = track
        .x_quantiles_5_95()
        .map_or(1.0, |(lo, hi)| hi - lo)
        .max(1e-12);
    Track::new(
        track
            .xy
            .iter()
            .map(|p| [(p[0] - mx) / range, (p[1] - my) / range])
            .collect(),
    )
}

/// One condition's results.
#[derive(Clone, Debug, Serialize)]
pub struct SplicedCondition {
    /// `clean`, `noise_0.1`, ... or `rendered`.
    pub condition: String,
    pub methods: Vec<MethodResult>,
    pub calibration: WindowCalibration,
}

/// A real talking-face video localized whole.
#[derive(Clone, Debug, Serialize)]
pub struct WebcamLocalization {
    pub recording: String,
    pub seconds: f64,
    /// Seconds with a reading probability (some window covers them).
    pub scored_s: f64,
    /// Share of the scored seconds inside reading segments (all false).
    pub false_reading_fraction: f64,
    pub segments: Vec<(f64, f64)>,
}

/// What [`evaluate_spliced`] measured.
#[derive(Clone, Debug, Serialize)]
pub struct SplicedEval {
    pub protocol: String,
    pub model: String,
    pub threshold: f64,
    pub options: SpliceOptions,
    pub readers: Vec<String>,
    pub others: Vec<String>,
    pub reading_segments: usize,
    pub seconds: f64,
    pub conditions: Vec<SplicedCondition>,
    pub webcam: Vec<WebcamLocalization>,
    /// All webcam talkers' scored seconds together.
    pub webcam_false_reading_fraction: Option<f64>,
}

/// A real eye-tracker recording at 25 fps (its gap-free pieces joined),
/// read as the protocol's first render mode reads sources.
fn clean_track(p: &Protocol, r: &RecordingSpec) -> Result<Track> {
    let (_, spec) = p.modes.iter().next().expect("a protocol has modes");
    let cfg = DatasetConfig::load(&p.resolve(&spec.render))?;
    let mut source = r.source.clone();
    *source.path_mut() = p.resolve(r.source.path());
    let mut xy = Vec::new();
    for rec in eyereplay_sources::read_source(&source, &cfg.read)? {
        for seg in &rec.segments {
            let v: Vec<_> = seg.samples().iter().collect();
            xy.extend(resample_samples(&v).xy);
        }
    }
    Ok(Track::new(xy))
}

/// The protocol's rendering of `r` in its first mode, read back, if the
/// protocol was run into `dir` (`real/<mode>/<name>`).
fn rendered_track(
    p: &Protocol,
    r: &RecordingSpec,
    dir: &Path,
    cache: &Path,
    progress: &dyn Progress,
) -> Result<Option<Track>> {
    let (mode, _) = p.modes.iter().next().expect("a protocol has modes");
    let d: PathBuf = dir.join("real").join(mode).join(&r.name);
    if !d.join("labels.csv").is_file() {
        return Ok(None);
    }
    let tracks = dataset_tracks(&[d], TrainInput::Extracted, cache, progress)?;
    Ok(Some(Track::new(
        tracks.into_iter().flat_map(|t| t.track.xy).collect(),
    )))
}

/// Localizes spliced streams of the real recordings of the detector
/// protocol at `protocol_path` with `detector`; the
/// `rendered` condition when `rendered_from` holds that protocol's output.
pub fn evaluate_spliced(
    protocol_path: &Path,
    detector: crate::NamedDetector<'_>,
    threshold: f64,
    opts: &SpliceOptions,
    rendered_from: Option<&Path>,
    cache: &Path,
    progress: &dyn Progress,
) -> Result<SplicedEval> {
    let (model, model_path) = (detector.model, detector.name);
    let p = Protocol::load(protocol_path)?;
    // Holding fixation is too easy a negative to prove anything; the
    // streams use the real tasks.
    let tracker: Vec<&RecordingSpec> = p
        .recording
        .iter()
        .filter(|r| !r.is_webcam() && !r.trivial)
        .collect();
    let names = |reading: bool| -> Vec<String> {
        tracker
            .iter()
            .filter(|r| r.reading == reading)
            .map(|r| r.name.clone())
            .collect()
    };
    let (readers, others) = (names(true), names(false));
    if readers.is_empty() || others.is_empty() {
        return Err(Error::input(
            protocol_path,
            format!(
                "splicing needs eye-tracker recordings of both classes; found {} reading and {} other (webcam and trivial ones are not spliced)",
                readers.len(),
                others.len()
            ),
        ));
    }
    let mut clean = Vec::new();
    let mut rendered = Vec::new();
    for r in &tracker {
        progress.info(&format!("reading {}", r.name));
        clean.push((r.name.clone(), on_one_scale(&clean_track(&p, r)?)));
        if let Some(dir) = rendered_from {
            if let Some(t) = rendered_track(&p, r, dir, cache, progress)? {
                rendered.push((r.name.clone(), on_one_scale(&t)));
            }
        }
    }
    let plan = plan_streams(&readers, &others, opts);
    let clean_streams = build_streams(&plan, &clean);
    let mut sets: Vec<(String, Vec<LabeledStream>)> = vec![("clean".into(), clean_streams.clone())];
    // The protocol's white-noise levels k (times the x range), as
    // evaluate-detector adds them; its 0 is the clean streams above.
    for &k in p.noise_levels.iter().filter(|&&k| k > 0.0) {
        let noisy = clean_streams
            .iter()
            .enumerate()
            .map(|(i, (t, f))| {
                let seed = name_seed(opts.seed ^ k.to_bits(), &format!("stream{i}"));
                (with_white_noise(t, k, seed), f.clone())
            })
            .collect();
        sets.push((format!("noise_{k}"), noisy));
    }
    let all_rendered = rendered.len() == tracker.len();
    if rendered_from.is_some() && !all_rendered {
        progress.info(&format!(
            "rendered condition skipped: {} of {} recordings rendered in {}",
            rendered.len(),
            tracker.len(),
            rendered_from
                .map(|d| d.display().to_string())
                .unwrap_or_default()
        ));
    }
    if all_rendered {
        sets.push(("rendered".into(), build_streams(&plan, &rendered)));
    }
    let conditions = sets
        .iter()
        .map(|(name, streams)| {
            let (tracks, flags): (Vec<Track>, Vec<Vec<bool>>) = streams.iter().cloned().unzip();
            SplicedCondition {
                condition: name.clone(),
                methods: Method::ALL
                    .into_iter()
                    .map(|m| score_method(&tracks, &flags, model, m, threshold))
                    .collect(),
                calibration: window_calibration(&tracks, &flags, model),
            }
        })
        .collect();

    let mut webcam = Vec::new();
    for r in p.recording.iter().filter(|r| r.is_webcam()) {
        let video = p.resolve(r.source.path());
        let csv = extract_cached(&[video], cache, progress)?.remove(0);
        let track = extract_csv_track(&csv)?;
        let (frame_p, loc) =
            localize::localize_frames(&track, model, localize::DEFAULT_METHOD, threshold);
        let segments: Vec<(f64, f64)> = loc.segments.iter().map(|s| (s.start_s, s.end_s)).collect();
        let scored: Vec<usize> = (0..frame_p.len())
            .filter(|&k| frame_p[k].is_finite())
            .collect();
        let called = scored
            .iter()
            .filter(|&&k| {
                let t = k as f64 / FPS;
                segments.iter().any(|&(a, b)| a <= t && t < b)
            })
            .count();
        webcam.push(WebcamLocalization {
            recording: r.name.clone(),
            seconds: track.duration_s(),
            scored_s: scored.len() as f64 / FPS,
            false_reading_fraction: called as f64 / scored.len().max(1) as f64,
            segments,
        });
    }
    let scored: f64 = webcam.iter().map(|w| w.scored_s).sum();
    let webcam_false_reading_fraction = (scored > 0.0).then(|| {
        webcam
            .iter()
            .map(|w| w.false_reading_fraction * w.scored_s)
            .sum::<f64>()
            / scored
    });
    let reading_segments = clean_streams
        .iter()
        .map(|(_, f)| true_segments(f).len())
        .sum();
    let seconds = clean_streams.iter().map(|(t, _)| t.duration_s()).sum();
    Ok(SplicedEval {
        protocol: protocol_path.display().to_string(),
        model: model_path.display().to_string(),
        threshold,
        options: opts.clone(),
        readers,
        others,
        reading_segments,
        seconds,
        conditions,
        webcam,
        webcam_false_reading_fraction,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(v: &[&str]) -> Vec<String> {
        v.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn streams_alternate_classes_fill_their_length_and_repeat_with_the_seed() {
        let opts = SpliceOptions {
            streams: 5,
            ..Default::default()
        };
        let plan = plan_streams(&names(&["r1", "r2"]), &names(&["o1", "o2", "o3"]), &opts);
        assert_eq!(plan.len(), 5);
        for pieces in &plan {
            let total: usize = pieces.iter().map(|p| p.frames).sum();
            assert_eq!(total, 7500);
            for w in pieces.windows(2) {
                assert_ne!(w[0].reading, w[1].reading);
            }
            for p in &pieces[..pieces.len() - 1] {
                let (lo, hi) = if p.reading {
                    (20.0, 60.0)
                } else {
                    (30.0, 90.0)
                };
                let s = p.frames as f64 / FPS;
                assert!(s >= lo && s <= hi, "{s}");
                assert_eq!(p.recording.starts_with('r'), p.reading);
            }
        }
        assert_eq!(
            plan,
            plan_streams(&names(&["r1", "r2"]), &names(&["o1", "o2", "o3"]), &opts)
        );
    }

    #[test]
    fn a_splice_copies_each_piece_from_its_offset_and_wraps_round() {
        let a = Track::new((0..10).map(|k| [k as f64, 0.0]).collect());
        let b = Track::new((0..4).map(|k| [100.0 + k as f64, 1.0]).collect());
        let pieces = vec![
            Piece {
                recording: "a".into(),
                reading: true,
                offset: 0.75,
                frames: 4,
            },
            Piece {
                recording: "b".into(),
                reading: false,
                offset: 0.5,
                frames: 3,
            },
        ];
        let (t, f) = splice(&pieces, &[("a".into(), a), ("b".into(), b)]);
        let xs: Vec<f64> = t.xy.iter().map(|p| p[0]).collect();
        // a from frame 7 (0.75 of 10): 7, 8, 9, then 0; b from frame 2: 102, 103, 100.
        assert_eq!(xs, [7.0, 8.0, 9.0, 0.0, 102.0, 103.0, 100.0]);
        assert_eq!(f, [true, true, true, true, false, false, false]);
        assert_eq!(crate::localization_eval::true_runs(&f), [(0.0, 4.0 / FPS)]);
    }

    #[test]
    fn one_scale_puts_the_median_at_zero_and_the_x_range_at_one() {
        // x = 0..=100 (5-95 % quantiles 5 and 95: range 90), y = 2x.
        let t = Track::new((0..=100).map(|k| [k as f64, 2.0 * k as f64]).collect());
        let s = on_one_scale(&t);
        let (lo, hi) = s.x_quantiles_5_95().unwrap();
        assert!((hi - lo - 1.0).abs() < 1e-12);
        assert!(s.xy[50][0].abs() < 1e-12 && s.xy[50][1].abs() < 1e-12);
        assert!((s.xy[100][1] - 100.0 / 90.0).abs() < 1e-12);
    }
}
