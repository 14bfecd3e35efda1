//! Paper stages 2-5 and the trajectory dataset.
//!
//! ```text
//! Recording (NormPos, native rate)
//!   -> blink filter (3 IQR, forward fill)          stage 2
//!   -> calibration c = s (n - 0.5) + mu             stage 2
//!   -> EdgeGauss smoothing (video sources)          stage 2b (ours)
//!   -> resample to fps + speed correction           stage 3
//!   -> shift mean to the global mean                stage 4
//!   -> concatenate per class, speed scale, slice    stage 5
//! ```
//!
//! Per-recording work runs in parallel; every reduction happens in a fixed
//! order afterwards, so outputs are byte-identical from run to run.

mod calibrate;
mod config;
mod error;
mod load;
mod resample;
mod slice;

pub use calibrate::{
    auto_calibration, blink_filter, manual_calibration, Calibration, FillAxes, FillCounts,
};
pub use config::{
    describe_toml_error, AppliesTo, BlinkFilterConfig, CalibrationConfig, CalibrationMode,
    CalibrationScope, ClassConfig, DatasetConfig, ResampleConfig, SmoothingConfig, SmoothingMethod,
    SpeedCorrection,
};
pub use error::{ConfigError, PrepareError};
pub use load::{check_source_files, generated_sources, load_sources};
pub use resample::{
    is_linear_rate, resample_recording, resampled_times, scale_about_centroid, ResampleMethod,
    SpeedCorrectionReport,
};
pub use slice::{normalize_to, reuse_ratio, slice_index, slice_session, stride};

use eyereplay_core::{CanvasPos, GazeClass, NormPos, Trajectory};
use eyereplay_signal::{edge_gauss, EdgeGaussReport};
use eyereplay_sources::{Recording, RecordingKind};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// One source after stage 3: frames, their blink flags, each frame's time
/// in the source recording, and its report.
type SourceFrames = (Vec<CanvasPos>, Vec<bool>, Vec<f64>, Vec<bool>, SourceReport);

/// `[[lo_x, hi_x], [lo_y, hi_y]]`: the percentile ranges behind an auto calibration.
pub type PercentileRanges = [[f64; 2]; 2];

/// A recording to prepare, with where it came from.
#[derive(Clone, Debug)]
pub struct SourceInput {
    pub class: GazeClass,
    pub recording: Recording,
    /// The configured file and its format, for provenance.
    pub file: String,
    pub format: String,
    pub sha256: String,
    /// Set for a recording a behaviour model generated.
    pub behaviour: Option<GeneratedSource>,
}

/// What a behaviour model made besides the samples.
#[derive(Clone, Debug)]
pub struct GeneratedSource {
    /// The person's drawn parameters and outcome, for `metadata.json`.
    pub record: serde_json::Value,
    /// `[start, end)` s of the stretches in which the person reads.
    pub reading_spans: Vec<[f64; 2]>,
}

/// What happened to one source, for `metadata.json` and the run summary.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SourceReport {
    pub index: usize,
    pub id: String,
    pub class: GazeClass,
    pub file: String,
    pub format: String,
    pub sha256: String,
    pub kind: RecordingKind,
    pub rate_hz: f64,
    pub samples: usize,
    pub segments: usize,
    pub duration_s: f64,
    pub frames: usize,
    pub px_per_deg: Option<f64>,
    pub filled: FillCounts,
    pub calibration: Calibration,
    pub smoothing: Option<EdgeGaussReport>,
    pub speed_correction: SpeedCorrectionReport,
    pub normalization_shift_px: [f64; 2],
    /// A generated person's drawn parameters and what they did.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub behaviour: Option<serde_json::Value>,
}

/// One class after stage 5.
#[derive(Clone, Debug)]
pub struct ClassOutput {
    pub class: GazeClass,
    /// The concatenated, normalized pool before the speed scale.
    pub pool: Vec<CanvasPos>,
    /// Source index of each pool frame.
    pub pool_source: Vec<u32>,
    /// Time of each pool frame in its source recording (s, the recording's
    /// own clock): where a frame came from, e.g. to look up the source
    /// video's head pose at that moment.
    pub pool_time_s: Vec<f64>,
    pub speed_scale: f64,
    pub stride: usize,
    pub reuse_ratio: f64,
    pub sessions: Vec<Vec<CanvasPos>>,
    /// Per session, per frame: the source blinked here.
    pub session_blinks: Vec<Vec<bool>>,
    /// Per session, per frame: the person reads here (a real source's
    /// frames all carry its class; a generated interview switches).
    pub session_reading: Vec<Vec<bool>>,
    /// Source indices present in each session, in order of appearance.
    pub session_sources: Vec<Vec<u32>>,
}

#[derive(Clone, Debug)]
pub struct Prepared {
    /// The calibration shared by all sources (pooled scope), else `None`.
    pub calibration: Option<Calibration>,
    /// Percentile ranges behind an auto calibration, `[[lo_x, hi_x], [lo_y, hi_y]]`.
    pub calibration_ranges: Option<[[f64; 2]; 2]>,
    pub global_mean: CanvasPos,
    pub sources: Vec<SourceReport>,
    pub classes: Vec<ClassOutput>,
    pub warnings: Vec<String>,
}

/// Runs stages 2-5 on loaded recordings: one call per documented stage.
pub fn prepare(cfg: &DatasetConfig, inputs: &[SourceInput]) -> Result<Prepared, PrepareError> {
    check_every_class_has_a_source(cfg, inputs)?;
    let filtered = filter_blinks(cfg, inputs);
    let calibrations = calibrate(cfg, inputs, &filtered)?;
    let Resampled {
        mut frames,
        blink_flags,
        times_s,
        reading,
        mut reports,
    } = resample_sources(cfg, inputs, &filtered, &calibrations)?;
    let global_mean = normalize(cfg, &mut frames, &mut reports);
    check_finite(inputs, &frames, &calibrations)?;
    let mut warnings = source_warnings(inputs, &filtered);
    let mut classes = Vec::new();
    for (class, cc) in &cfg.classes {
        let pool = concatenate(*class, inputs, &frames, &blink_flags, &times_s, &reading);
        let (out, warning) = slice_class(cfg, *class, cc, pool)?;
        warnings.extend(warning);
        classes.push(out);
    }
    let (calibration, calibration_ranges) = match calibrations.pooled {
        Some((c, r)) => (Some(c), r),
        None => (None, None),
    };
    Ok(Prepared {
        calibration,
        calibration_ranges,
        global_mean,
        sources: reports,
        classes,
        warnings,
    })
}

/// Every calibrated, normalized position is a number: a manual scale near
/// the largest float (`s_x = 1e308`) overflowed and wrote `NaN` into the
/// sessions, which `evaluate` then refused at the wrong line.
fn check_finite(
    inputs: &[SourceInput],
    frames: &[Vec<CanvasPos>],
    calibrations: &Calibrations,
) -> Result<(), PrepareError> {
    for ((input, f), c) in inputs.iter().zip(frames).zip(&calibrations.per_source) {
        if f.iter()
            .any(|p| !(p.x_px.is_finite() && p.y_px.is_finite()))
        {
            return Err(PrepareError::Source {
                id: input.recording.id.clone(),
                message: format!(
                    "the calibration (s = ({:.4e}, {:.4e}) px per unit n) puts its gaze beyond any number; \
                     check calibration.s_x and s_y",
                    c.s_x, c.s_y
                ),
            });
        }
    }
    Ok(())
}

/// A sample whose normalized position lies this far outside 0..1 (a screen
/// width or height beyond the screen) is not on the screen the source
/// describes.
const FAR_OFF_SCREEN_N: f64 = 1.0;

/// Warnings for a source whose data look wrong though they read: mostly
/// filled (invalid or blink samples replaced by the last valid one, so the
/// class is a few held points), or mostly far off its screen (a wrong
/// `screen_px` or unit: with the pooled calibration it also flattens every
/// other source, whose range it sets).
fn source_warnings(inputs: &[SourceInput], filtered: &[Filtered]) -> Vec<String> {
    let mut out = Vec::new();
    for (input, (segments, fill)) in inputs.iter().zip(filtered) {
        let id = &input.recording.id;
        let n: usize = segments.iter().map(|s| s.len()).sum();
        if n > 0 && fill.invalid_or_blink * 2 > n {
            out.push(format!(
                "{id}: {:.2} % of its {n} samples were invalid or blinks and were filled with the last valid one",
                100.0 * fill.invalid_or_blink as f64 / n as f64
            ));
        }
        let far = |v: f64| !(-FAR_OFF_SCREEN_N..=1.0 + FAR_OFF_SCREEN_N).contains(&v);
        let (mut off, mut max_n) = (0usize, 0.0f64);
        for p in segments.iter().flat_map(|s| s.positions()) {
            if far(p.nx) || far(p.ny) {
                off += 1;
                max_n = max_n.max(p.nx.abs()).max(p.ny.abs());
            }
        }
        if n > 0 && off * 10 > n {
            out.push(format!(
                "{id}: {:.1} % of its gaze lies more than a screen away from the screen \
                 (up to {max_n:.3e} screen widths or heights): a wrong screen_px, or another unit?",
                100.0 * off as f64 / n as f64
            ));
        }
    }
    out
}

fn check_every_class_has_a_source(
    cfg: &DatasetConfig,
    inputs: &[SourceInput],
) -> Result<(), PrepareError> {
    for class in cfg.classes.keys() {
        if !inputs.iter().any(|s| s.class == *class) {
            return Err(PrepareError::Class {
                class: class.to_string(),
                message: "no source could be read".into(),
            });
        }
    }
    Ok(())
}

/// A recording after the blink filter, with what the filter replaced.
type Filtered = (Vec<Trajectory<NormPos>>, FillCounts);

/// Paper stage 2, blink filtering: per recording, in parallel. The IQR rule
/// applies to video sources unless `blink_filter.iqr_applies_to = "all"`;
/// invalid and blink-flagged samples are filled for every source.
fn filter_blinks(cfg: &DatasetConfig, inputs: &[SourceInput]) -> Vec<Filtered> {
    inputs
        .par_iter()
        .map(|s| {
            let iqr = cfg.blink_filter.iqr_applies_to == AppliesTo::All
                || s.recording.kind == RecordingKind::Video;
            // `per_axis` (the paper) unless the config says `joint`.
            blink_filter(
                &s.recording.segments,
                &cfg.blink_filter,
                iqr,
                cfg.blink_filter.fill,
            )
        })
        .collect()
}

/// The calibrations of one run.
struct Calibrations {
    /// The one shared by all sources (manual, or auto with pooled scope),
    /// with the percentile ranges behind an auto calibration.
    pooled: Option<(Calibration, Option<PercentileRanges>)>,
    /// The calibration of each source, in source order.
    per_source: Vec<Calibration>,
}

/// Paper stage 2, geometric calibration `c = s (n - 0.5) + mu` (eq. 2):
/// manual, or auto-scaled from percentiles, pooled over all sources by
/// default. Pooled, each source contributes about one sample per target
/// frame, so a 500 Hz tracker does not outweigh a 25 fps video twenty times
/// over; per source, every sample counts.
fn calibrate(
    cfg: &DatasetConfig,
    inputs: &[SourceInput],
    filtered: &[Filtered],
) -> Result<Calibrations, PrepareError> {
    let calib_for = |idx: usize| -> Result<(Calibration, Option<PercentileRanges>), PrepareError> {
        if let Some(c) = manual_calibration(&cfg.calibration) {
            return Ok((c, None));
        }
        let pick: Vec<usize> = match cfg.calibration.scope {
            CalibrationScope::Pooled => (0..inputs.len()).collect(),
            CalibrationScope::PerSource => vec![idx],
        };
        let mut pts = Vec::new();
        for i in pick {
            // Thinning only balances sources against each other; alone, a
            // source's percentiles are best estimated from all its samples.
            let step = match cfg.calibration.scope {
                CalibrationScope::Pooled => {
                    ((inputs[i].recording.rate_hz / cfg.fps).round() as usize).max(1)
                }
                CalibrationScope::PerSource => 1,
            };
            pts.extend(
                filtered[i]
                    .0
                    .iter()
                    .flat_map(|s| s.positions().step_by(step)),
            );
        }
        auto_calibration(&pts, &cfg.calibration, cfg.canvas)
            .map(|(c, r)| (c, Some(r)))
            .ok_or_else(|| PrepareError::Source {
                id: inputs[idx].recording.id.clone(),
                message: "gaze does not move on one axis (5th and 95th percentiles equal): cannot auto-scale; set calibration.mode = \"manual\"".into(),
            })
    };
    match (cfg.calibration.mode, cfg.calibration.scope) {
        (CalibrationMode::Manual, _) | (_, CalibrationScope::Pooled) => {
            let pooled = calib_for(0)?;
            Ok(Calibrations {
                per_source: vec![pooled.0; inputs.len()],
                pooled: Some(pooled),
            })
        }
        _ => {
            let each: Vec<_> = (0..inputs.len())
                .into_par_iter()
                .map(|i| calib_for(i).map(|(c, _)| c))
                .collect();
            // Collected first, then checked in order: the first failing
            // source is the one reported, whatever the thread timing.
            Ok(Calibrations {
                pooled: None,
                per_source: each.into_iter().collect::<Result<_, _>>()?,
            })
        }
    }
}

/// Every source after stage 3, in source order.
struct Resampled {
    frames: Vec<Vec<CanvasPos>>,
    /// Per frame: the source blinked here.
    blink_flags: Vec<Vec<bool>>,
    /// Per frame: its time in the source recording (s).
    times_s: Vec<Vec<f64>>,
    /// Per frame: the person reads here.
    reading: Vec<Vec<bool>>,
    reports: Vec<SourceReport>,
}

/// Per source: calibration applied, EdgeGauss smoothing (stage 2b, ours),
/// then paper stage 3: resampling to the target rate with the speed
/// correction `alpha = L_orig / L_resamp` where it applies. In parallel;
/// results in source order.
fn resample_sources(
    cfg: &DatasetConfig,
    inputs: &[SourceInput],
    filtered: &[Filtered],
    calibrations: &Calibrations,
) -> Result<Resampled, PrepareError> {
    let per_source: Vec<Result<SourceFrames, PrepareError>> = inputs
        .par_iter()
        .enumerate()
        .map(|(i, s)| {
            let calib = calibrations.per_source[i];
            let (segs, filled) = &filtered[i];
            let mut canvas: Vec<Trajectory<CanvasPos>> = segs
                .iter()
                .map(|t| t.map(|n| calib.norm_to_canvas(n)))
                .collect();
            let smoothing = smooth(cfg, s.recording.kind, &mut canvas)?;
            let (frames, blinks, speed) =
                resample_recording(&canvas, s.recording.rate_hz, cfg.fps, &cfg.resample);
            let times = resampled_times(&canvas, cfg.fps);
            debug_assert_eq!(times.len(), frames.len());
            let reading: Vec<bool> = match &s.behaviour {
                Some(b) => times
                    .iter()
                    .map(|t| b.reading_spans.iter().any(|r| *t >= r[0] && *t < r[1]))
                    .collect(),
                None => vec![s.class == GazeClass::Reading; times.len()],
            };
            if frames.len() < 2 {
                return Err(PrepareError::Source {
                    id: s.recording.id.clone(),
                    message: format!(
                        "only {} frame(s) at {} fps: recording too short",
                        frames.len(),
                        cfg.fps
                    ),
                });
            }
            let rep = SourceReport {
                index: i,
                id: s.recording.id.clone(),
                class: s.class,
                file: s.file.clone(),
                format: s.format.clone(),
                sha256: s.sha256.clone(),
                kind: s.recording.kind,
                rate_hz: s.recording.rate_hz,
                samples: s.recording.sample_count(),
                segments: s.recording.segments.len(),
                duration_s: s.recording.segments.iter().map(|t| t.duration_s()).sum(),
                frames: frames.len(),
                px_per_deg: s.recording.px_per_deg,
                filled: *filled,
                calibration: calib,
                smoothing,
                speed_correction: speed,
                normalization_shift_px: [0.0, 0.0],
                behaviour: s.behaviour.as_ref().map(|b| b.record.clone()),
            };
            Ok((frames, blinks, times, reading, rep))
        })
        .collect();
    let mut frames = Vec::with_capacity(per_source.len());
    let mut blink_flags = Vec::with_capacity(per_source.len());
    let mut times_s = Vec::with_capacity(per_source.len());
    let mut reading = Vec::with_capacity(per_source.len());
    let mut reports = Vec::with_capacity(per_source.len());
    for r in per_source {
        let (f, b, t, rd, rep) = r?;
        frames.push(f);
        blink_flags.push(b);
        times_s.push(t);
        reading.push(rd);
        reports.push(rep);
    }
    Ok(Resampled {
        frames,
        blink_flags,
        times_s,
        reading,
        reports,
    })
}

/// Stage 2b (ours, the paper names EdgeGauss without a formula): smooths
/// each segment in canvas pixels at the source rate, when the config applies
/// it to this kind of source. Returns the summed report, `None` if skipped.
fn smooth(
    cfg: &DatasetConfig,
    kind: RecordingKind,
    canvas: &mut [Trajectory<CanvasPos>],
) -> Result<Option<EdgeGaussReport>, PrepareError> {
    let smooth = cfg.smoothing.method == SmoothingMethod::EdgeGauss
        && (cfg.smoothing.apply_to == AppliesTo::All || kind == RecordingKind::Video);
    if !smooth {
        return Ok(None);
    }
    let mut total = EdgeGaussReport::default();
    for t in canvas {
        let times: Vec<f64> = t.samples().iter().map(|x| x.t_s).collect();
        let vals: Vec<[f64; 2]> = t.positions().map(|p| [p.x_px, p.y_px]).collect();
        let (sm, rep) = edge_gauss(&times, &vals, &cfg.smoothing.params());
        total.edges += rep.edges;
        total.noise_sigma = total.noise_sigma.max(rep.noise_sigma);
        total.threshold = total.threshold.max(rep.threshold);
        let samples: Vec<_> = t
            .samples()
            .iter()
            .zip(&sm)
            .map(|(x, p)| eyereplay_core::Sample {
                pos: CanvasPos {
                    x_px: p[0],
                    y_px: p[1],
                },
                ..*x
            })
            .collect();
        *t = Trajectory::new(samples)?;
    }
    Ok(Some(total))
}

/// Paper stage 4, normalization (eq. 5): every source's frames are shifted
/// so their mean lies on the global mean over every frame of every source.
/// Records each source's shift in its report; returns the global mean.
fn normalize(
    cfg: &DatasetConfig,
    frames: &mut [Vec<CanvasPos>],
    reports: &mut [SourceReport],
) -> CanvasPos {
    let global_mean =
        eyereplay_core::mean_of(frames.iter().flatten().copied()).unwrap_or(cfg.canvas.center());
    for (f, rep) in frames.iter_mut().zip(reports.iter_mut()) {
        rep.normalization_shift_px = normalize_to(f, global_mean);
    }
    global_mean
}

/// One class's sources concatenated in config order (paper stage 4's pool).
struct Pool {
    frames: Vec<CanvasPos>,
    /// Source index of each frame.
    source: Vec<u32>,
    /// Whether the source blinked at each frame.
    blink: Vec<bool>,
    /// Each frame's time in its source recording (s).
    time_s: Vec<f64>,
    /// Whether the person reads at each frame.
    reading: Vec<bool>,
}

/// Paper stage 4, concatenation: the normalized frames of one class's
/// sources, in config order, with each frame's source and blink flag.
fn concatenate(
    class: GazeClass,
    inputs: &[SourceInput],
    frames: &[Vec<CanvasPos>],
    blink_flags: &[Vec<bool>],
    times_s: &[Vec<f64>],
    reading: &[Vec<bool>],
) -> Pool {
    let mut pool = Pool {
        frames: Vec::new(),
        source: Vec::new(),
        blink: Vec::new(),
        time_s: Vec::new(),
        reading: Vec::new(),
    };
    for (i, f) in frames.iter().enumerate() {
        if inputs[i].class == class {
            pool.frames.extend_from_slice(f);
            pool.blink.extend_from_slice(&blink_flags[i]);
            pool.time_s.extend_from_slice(&times_s[i]);
            pool.reading.extend_from_slice(&reading[i]);
            pool.source.extend(std::iter::repeat_n(i as u32, f.len()));
        }
    }
    pool
}

/// Paper stage 5: the class's speed scale about the pool centroid (eq. 6),
/// then circular slicing `idx_j = (i floor(T/N) + j) mod T` (eq. 4) into N
/// sessions of F frames. Also returns the reuse-ratio warning, if any.
fn slice_class(
    cfg: &DatasetConfig,
    class: GazeClass,
    cc: &ClassConfig,
    pool: Pool,
) -> Result<(ClassOutput, Option<String>), PrepareError> {
    let t = pool.frames.len();
    let n = cc.sessions;
    if t < n {
        return Err(PrepareError::Class {
            class: class.to_string(),
            message: format!(
                "{t} frames at {} fps cannot give {n} sessions (stride floor(T/N) would be 0); add sources or lower sessions",
                cfg.fps
            ),
        });
    }
    let reuse = reuse_ratio(t, n, cfg.session_frames);
    let f = cfg.session_frames;
    let warning = (reuse > 1.0).then(|| {
        // Said in seconds too, with what it means for the sessions and the
        // fix: a ratio alone read as jargon.
        let (session_s, pool_s) = (f as f64 / cfg.fps, t as f64 / cfg.fps);
        let stride = t / n;
        let what = if f > t {
            format!(
                "each {session_s:.0}-s session is longer than the class's {pool_s:.0} s of gaze, so it repeats it {:.1} times",
                f as f64 / t as f64
            )
        } else if stride < f {
            format!(
                "consecutive sessions share {} of their {f} frames ({:.0} %)",
                f - stride,
                100.0 * (f - stride) as f64 / f as f64
            )
        } else {
            "sessions reuse the pool".to_string()
        };
        format!(
            "class '{class}': reuse ratio N*F/T = {n}*{f}/{t} = {reuse:.2}: each source frame appears {reuse:.1} times on average ({what}); \
             add sources, or lower sessions or session_frames (the paper's larger KS gap for reading came from a reuse ratio near 11)"
        )
    });
    let scale = cfg.speed_scale(class);
    let mut scaled = pool.frames.clone();
    scale_about_centroid(&mut scaled, scale);
    let mut sessions = Vec::with_capacity(n);
    let mut session_blinks = Vec::with_capacity(n);
    let mut session_reading = Vec::with_capacity(n);
    let mut session_sources = Vec::with_capacity(n);
    for i in 0..n {
        sessions.push(slice_session(&scaled, i, n, cfg.session_frames));
        session_blinks.push(slice_session(&pool.blink, i, n, cfg.session_frames));
        session_reading.push(slice_session(&pool.reading, i, n, cfg.session_frames));
        let src = slice_session(&pool.source, i, n, cfg.session_frames);
        let mut seen: Vec<u32> = Vec::new();
        for s in src {
            if seen.last() != Some(&s) && !seen.contains(&s) {
                seen.push(s);
            }
        }
        session_sources.push(seen);
    }
    Ok((
        ClassOutput {
            class,
            pool: pool.frames,
            pool_source: pool.source,
            pool_time_s: pool.time_s,
            speed_scale: scale,
            stride: stride(t, n),
            reuse_ratio: reuse,
            sessions,
            session_blinks,
            session_reading,
            session_sources,
        },
        warning,
    ))
}

/// Counts for `--dry-run` and the summary line.
#[derive(Clone, Debug, Serialize)]
pub struct Plan {
    pub classes: BTreeMap<GazeClass, PlanClass>,
    pub video_hours: f64,
}

#[derive(Clone, Debug, Serialize)]
pub struct PlanClass {
    pub sessions: usize,
    pub pool_frames: usize,
    pub reuse_ratio: f64,
}

impl Prepared {
    pub fn plan(&self, cfg: &DatasetConfig) -> Plan {
        let mut classes = BTreeMap::new();
        let mut total = 0usize;
        for c in &self.classes {
            classes.insert(
                c.class,
                PlanClass {
                    sessions: c.sessions.len(),
                    pool_frames: c.pool.len(),
                    reuse_ratio: c.reuse_ratio,
                },
            );
            total += c.sessions.len();
        }
        Plan {
            classes,
            video_hours: total as f64 * cfg.session_frames as f64 / cfg.fps / 3600.0,
        }
    }
}
