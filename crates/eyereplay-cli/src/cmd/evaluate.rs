use anyhow::{bail, Context};
use eyereplay_core::{read_session_csv, CanvasPos};
use eyereplay_eval::dataset::{read_blink_column, read_truth_norm};
use eyereplay_eval::{
    compare_visual, dataset::session_calibrations, evaluate_dataset, read_calibration,
    rendered_video_path, truth_csv_path, write_report, EvalConfig, Evaluation, IvtThresholds,
    VisualRun, VisualSection,
};
use std::path::{Path, PathBuf};

/// Measure a dataset's fidelity and write report/index.html and report/metrics.json.
///
/// Distributional fidelity: speed, fixation duration and saccade amplitude
/// of the generated sessions against their source pool (two-sample KS as
/// scipy's ks_2samp, Q-Q plots, 30-s time-series windows), plus rates, main
/// sequence, dispersion, blink rate and per-session events in pymovements'
/// layout. Visual fidelity (when a session has been rendered, or with
/// --video/--trajectory): the iris extracted from the video against the
/// source, frame by frame.
#[derive(clap::Args)]
#[command(after_help = "Examples:\n  \
eyereplay evaluate data/                 # writes data/report/index.html and metrics.json\n  \
eyereplay evaluate data/ --json | jq .distribution.reading.speed\n  \
eyereplay evaluate data/ --visual-session reading/reading_0003.csv --visual-seconds 120\n  \
eyereplay evaluate data/ --video other_sim.mp4 --trajectory other_sim.csv")]
pub struct Args {
    /// Dataset folder written by 'eyereplay prepare' (labels.csv, metadata.json, pool/).
    pub dataset_dir: PathBuf,
    /// Also print metrics.json to standard output.
    #[arg(long)]
    pub json: bool,
    /// I-VT fixation threshold: speeds below this are fixation (px/frame).
    #[arg(long, default_value_t = 5.0, value_name = "PX_PER_FRAME")]
    pub fixation_below: f64,
    /// I-VT saccade threshold: speeds above this are saccade (px/frame).
    #[arg(long, default_value_t = 15.0, value_name = "PX_PER_FRAME")]
    pub saccade_above: f64,
    /// Length of the time-series windows in the report (s).
    #[arg(long, default_value_t = 30.0, value_name = "SECONDS")]
    pub window_s: f64,
    /// A KS D at or below this counts as a pass in the report.
    #[arg(long, default_value_t = 0.15)]
    pub d_max: f64,
    /// Canvas pixels per degree of visual angle, if the viewing geometry is
    /// known; adds saccade amplitudes in degrees.
    #[arg(long, value_name = "PX")]
    pub px_per_deg: Option<f64>,
    /// Skip the visual fidelity section.
    #[arg(long)]
    pub no_visual: bool,
    /// Session whose rendered video is compared (path relative to the
    /// dataset, as in labels.csv); default: the first rendered reading session.
    #[arg(long, value_name = "CSV")]
    pub visual_session: Option<String>,
    /// Any rendered video to judge (with --trajectory), e.g. another simulator's.
    #[arg(long, requires = "trajectory")]
    pub video: Option<PathBuf>,
    /// The frame,x,y canvas trajectory that drove --video; mapped back to
    /// normalized iris units with metadata.json's calibration.
    #[arg(long, requires = "video")]
    pub trajectory: Option<PathBuf>,
    /// Compare only the first this many seconds of the video (the paper: 120).
    #[arg(long, default_value_t = 120.0, value_name = "SECONDS")]
    pub visual_seconds: f64,
    /// Folder of the iris models (default: $EYEREPLAY_MODELS or .cache/models).
    #[arg(long, value_name = "DIR")]
    pub models: Option<PathBuf>,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    anyhow::ensure!(
        args.fixation_below > 0.0 && args.saccade_above >= args.fixation_below,
        "thresholds: need 0 < --fixation-below <= --saccade-above (got {} and {})",
        args.fixation_below,
        args.saccade_above
    );
    anyhow::ensure!(args.window_s > 0.0, "--window-s must be positive");
    anyhow::ensure!(
        args.visual_seconds > 0.0,
        "--visual-seconds must be positive"
    );
    let cfg = EvalConfig {
        thresholds: IvtThresholds {
            fixation_below_px_per_frame: args.fixation_below,
            saccade_above_px_per_frame: args.saccade_above,
            ..IvtThresholds::default()
        },
        window_s: args.window_s,
        d_max: args.d_max,
        px_per_deg: args.px_per_deg,
        ..EvalConfig::default()
    };
    let mut ev = evaluate_dataset(&args.dataset_dir, &cfg).context("evaluate")?;
    if args.no_visual {
        ev.visual = VisualSection::NotComputed {
            reason: "not computed: skipped with --no-visual".into(),
        };
    } else {
        ev.visual = visual_section(&args, &mut ev)?;
    }
    let (paths, metrics) =
        write_report(&args.dataset_dir, &ev).context("evaluate: writing the report")?;
    for c in &ev.classes {
        for m in &c.comparisons {
            match &m.ks {
                Some(k) => eprintln!(
                    "{:<13} {:<18} D = {:.4}  p = {:.3e}  (n = {} / {})",
                    c.class.name(),
                    m.metric.key(),
                    k.d,
                    k.p,
                    m.n_source,
                    m.n_generated
                ),
                None => eprintln!(
                    "{:<13} {:<18} no samples (n = {} / {})",
                    c.class.name(),
                    m.metric.key(),
                    m.n_source,
                    m.n_generated
                ),
            }
        }
    }
    match &ev.visual {
        VisualSection::NotComputed { reason } => eprintln!("visual fidelity: {reason}"),
        VisualSection::Computed(run) => {
            eprintln!(
                "visual fidelity ({}, {} frames): {}",
                run.video,
                run.fidelity.n_frames,
                run.fidelity.summary()
            );
        }
    }
    eprintln!("report: {}", paths.html.display());
    eprintln!("metrics: {}", paths.metrics.display());
    if args.json {
        print!("{metrics}");
    }
    Ok(())
}

/// Picks the video and trajectory to compare. An explicit --video must
/// work; the automatic choice quietly reports why it could not run.
fn visual_section(args: &Args, ev: &mut Evaluation) -> anyhow::Result<VisualSection> {
    let dir = &args.dataset_dir;
    let explicit = args.video.is_some() || args.visual_session.is_some();
    let (video, trajectory, truth, session) = match (&args.video, &args.trajectory) {
        (Some(v), Some(t)) => {
            if !v.is_file() {
                bail!("{}: not found", v.display());
            }
            (v.clone(), t.clone(), None, None)
        }
        _ => {
            let session = match &args.visual_session {
                Some(s) => s.clone(),
                None => {
                    let first = ev
                        .classes
                        .iter()
                        .flat_map(|c| c.events.iter().map(|(f, _)| f.clone()))
                        .find(|f| rendered_video_path(dir, f).is_file());
                    match first {
                        Some(f) => f,
                        None => {
                            return Ok(VisualSection::NotComputed {
                                reason: "not computed: no rendered session found (a video <class>/<stem>.mp4 \
beside a session CSV); run 'eyereplay render' first, or pass --video and --trajectory"
                                    .into(),
                            })
                        }
                    }
                }
            };
            let video = rendered_video_path(dir, &session);
            if !video.is_file() {
                bail!(
                    "{}: not found (the rendered video of {session})",
                    video.display()
                );
            }
            let truth = truth_csv_path(dir, &session);
            (
                video,
                dir.join(&session),
                truth.is_file().then_some(truth),
                Some(session),
            )
        }
    };
    let models = args
        .models
        .clone()
        .unwrap_or_else(eyereplay_extract::default_models_dir);
    let missing = eyereplay_extract::missing_files(&models);
    if !missing.is_empty() {
        let reason = format!(
            "not computed: iris models missing in {} ({}); run 'eyereplay models fetch'",
            models.display(),
            missing.join(", ")
        );
        if explicit {
            bail!("{reason}");
        }
        return Ok(VisualSection::NotComputed { reason });
    }
    let input: Vec<CanvasPos> = read_session_csv(&trajectory)?;
    check_frame_count(&video, input.len())?;
    // Canvas px back to normalized iris units, with the calibration that
    // produced each frame (pooled, or per source for a dataset session).
    let cals = match &session {
        Some(rel) => session_calibrations(dir, rel, input.len())?,
        None => vec![
            read_calibration(dir).context(
                "--trajectory needs the dataset's pooled calibration; \
for per-source calibrations compare a dataset session (--visual-session)"
            )?;
            input.len()
        ],
    };
    let source_all: Vec<[f64; 2]> = input
        .iter()
        .zip(&cals)
        .map(|(c, cal)| {
            let n = cal.canvas_to_norm(*c);
            [n.nx, n.ny]
        })
        .collect();
    // Frames where the eyes are closed (the session's or the render's blink
    // column) carry no iris position to compare.
    let mut closed = vec![false; input.len()];
    for p in [Some(trajectory.clone()), truth.clone()]
        .into_iter()
        .flatten()
    {
        if let Some(b) = read_blink_column(&p)? {
            for (c, b) in closed.iter_mut().zip(b) {
                *c |= b;
            }
        }
    }
    // Lids are part-closed just before and after a flagged blink too.
    let flagged = closed.clone();
    for (i, _) in flagged.iter().enumerate().filter(|(_, &b)| b) {
        for c in &mut closed[i.saturating_sub(2)..(i + 3).min(flagged.len())] {
            *c = true;
        }
    }
    if let Some(p) = truth {
        // The renderer's own iris positions against the source: the
        // simulator's mapping without the extractor.
        let t = read_truth_norm(&p)?;
        anyhow::ensure!(
            t.len() == input.len(),
            "{}: {} frames, but its trajectory has {}",
            p.display(),
            t.len(),
            input.len()
        );
        let n = ((args.visual_seconds * ev.fps).round() as usize).min(input.len());
        let t: Vec<[f64; 2]> = t[..n]
            .iter()
            .zip(&closed)
            .map(|(r, &c)| if c { [f64::NAN, f64::NAN] } else { *r })
            .collect();
        let cmp = compare_visual(&source_all[..n], &t, None)
            .with_context(|| format!("{}: comparing with the source", p.display()))?;
        ev.render_truth = Some((shown(&args.dataset_dir, &p), cmp));
    }
    let n = ((args.visual_seconds * ev.fps).round() as usize).min(input.len());
    let geometry = render_geometry_path(&video);
    // 1. The extractor's own pipeline (face detector -> mesh -> iris). When
    //    the render's geometry is at hand, a 4-s trial decides first whether
    //    the detector sees a face at all, so a close-up does not cost a
    //    full detector pass.
    let trial = (4.0 * ev.fps).round() as usize;
    let detected = if geometry.is_file() && n > trial {
        match extract_with_detector(&video, &models, trial, ev.fps) {
            Ok(r) if detection_rate(&r) < 0.5 => Ok(r),
            _ => extract_with_detector(&video, &models, n, ev.fps),
        }
    } else {
        extract_with_detector(&video, &models, n, ev.fps)
    };
    let (rendered_n, locator) = match detected {
        Ok(r) if detection_rate(&r) >= 0.5 || !geometry.is_file() => (
            r,
            "face detector, face mesh and iris model (eyereplay-extract)".to_string(),
        ),
        // 2. A close-up without a detectable face: the iris model on eye
        //    crops placed from the render's known eye corners.
        first => {
            if !geometry.is_file() {
                let e = first.expect_err("handled above");
                let reason = format!(
                    "not computed: {}; no render geometry ({}) to place the eye crops",
                    crate::format_chain(&e),
                    shown(dir, &geometry)
                );
                if explicit {
                    bail!("{reason}");
                }
                return Ok(VisualSection::NotComputed { reason });
            }
            let corners = render_eye_corners(&geometry)?;
            let r = extract_at_corners(&video, &models, corners, n)?;
            (
                r,
                format!(
                    "iris model on eye crops placed from the render's known geometry ({}; \
nx against its fixed eye corners, ny against the model's lids), \
because the face detector found the face in {} of the compared frames",
                    shown(dir, &geometry),
                    match &first {
                        Ok(r) => format!("{:.0} %", 100.0 * detection_rate(r)),
                        Err(_) => "none".to_string(),
                    }
                ),
            )
        }
    };
    let n = n.min(rendered_n.len());
    anyhow::ensure!(n >= 2, "{}: only {n} frame(s) decoded", video.display());
    let rendered_n: Vec<[f64; 2]> = rendered_n[..n]
        .iter()
        .zip(&closed)
        .map(|(r, &c)| if c { [f64::NAN, f64::NAN] } else { *r })
        .collect();
    let input = &input[..n];
    let source_n = source_all[..n].to_vec();
    let fidelity = compare_visual(&source_n, &rendered_n, Some((input, ev.canvas)))
        .with_context(|| format!("{}: visual comparison", video.display()))?;
    Ok(VisualSection::Computed(Box::new(VisualRun {
        fidelity,
        detection_rate: detection_rate(&rendered_n),
        source_n,
        rendered_n,
        video: shown(dir, &video),
        eye_locator: locator,
    })))
}

fn detection_rate(n: &[[f64; 2]]) -> f64 {
    n.iter()
        .filter(|p| p[0].is_finite() && p[1].is_finite())
        .count() as f64
        / n.len().max(1) as f64
}

/// Mean `(nx, ny)` of both eyes per frame for the first `n_max` frames by
/// the extractor's full pipeline; NaN where it found no open eyes.
fn extract_with_detector(
    video: &Path,
    models: &Path,
    n_max: usize,
    fps: f64,
) -> anyhow::Result<Vec<[f64; 2]>> {
    let opts = eyereplay_extract::ExtractOptions {
        models_dir: models.to_path_buf(),
        max_duration_s: Some(n_max as f64 / fps),
        ..Default::default()
    };
    let ext = eyereplay_extract::extract_many(
        &[video.to_path_buf()],
        &opts,
        &eyereplay_extract::NoProgress,
    )
    .pop()
    .expect("one result per video")
    .with_context(|| format!("{}: extracting the iris", video.display()))?;
    Ok(ext
        .rows
        .iter()
        .take(n_max)
        .map(|r| match r.mean_n() {
            Some((x, y)) if r.valid() => [x, y],
            _ => [f64::NAN, f64::NAN],
        })
        .collect())
}

/// The render's identity/geometry JSON beside a video: `<stem>_identity.json`
/// (written by 'eyereplay render --dataset', or by --identity-out).
fn render_geometry_path(video: &Path) -> PathBuf {
    let stem = video
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    video.with_file_name(format!("{stem}_identity.json"))
}

/// Eye corners in image px from the render geometry JSON (`eyes[k].
/// inner_corner_px / outer_corner_px`): image-left eye first, each pair
/// ordered left to right in the image.
fn render_eye_corners(path: &Path) -> anyhow::Result<eyereplay_extract::EyeCorners> {
    use eyereplay_extract::Pt;
    let text =
        std::fs::read_to_string(path).with_context(|| format!("{}: reading", path.display()))?;
    let j: serde_json::Value = serde_json::from_str(&text)
        .with_context(|| format!("{}: not valid JSON", path.display()))?;
    let eyes = j["eyes"]
        .as_array()
        .filter(|a| a.len() == 2)
        .with_context(|| format!("{}: expected 'eyes' with two entries", path.display()))?;
    let pt = |e: &serde_json::Value, k: &str| -> anyhow::Result<Pt> {
        let v = e[k]
            .as_array()
            .filter(|a| a.len() == 2)
            .and_then(|a| Some(Pt::new(a[0].as_f64()? as f32, a[1].as_f64()? as f32)))
            .with_context(|| format!("{}: eyes[].{k} must be [x, y]", path.display()))?;
        Ok(v)
    };
    let pair = |e: &serde_json::Value| -> anyhow::Result<_> {
        Ok((pt(e, "inner_corner_px")?, pt(e, "outer_corner_px")?))
    };
    Ok(eyereplay_extract::order_eye_corners([
        pair(&eyes[0])?,
        pair(&eyes[1])?,
    ]))
}

/// The extractor's iris step without face detection
/// ([`eyereplay_extract::EyeCropTracker`]): the iris model on eye crops
/// placed at the render's known corners as MediaPipe places them, box-filtered
/// down to the model's input; `nx` against those fixed corners (camera and
/// head do not move in a render), `ny` against the model's lids; blinks by
/// the extractor's aperture rule are NaN.
fn extract_at_corners(
    video: &Path,
    models: &Path,
    corners: eyereplay_extract::EyeCorners,
    n_max: usize,
) -> anyhow::Result<Vec<[f64; 2]>> {
    let m = eyereplay_extract::Models::load(models)?;
    let rows = eyereplay_extract::EyeCropTracker::new(m)
        .measure_video_rows(
            video,
            &corners,
            eyereplay_extract::CornerReference::Fixed,
            Some(n_max),
            eyereplay_extract::DEFAULT_BLINK_RATIO,
        )
        .with_context(|| format!("{}: measuring the eyes", video.display()))?;
    Ok(rows
        .iter()
        .map(|r| match r.mean_n() {
            Some((x, y)) if r.valid() => [x, y],
            _ => [f64::NAN, f64::NAN],
        })
        .collect())
}

/// A video whose frame count differs from its trajectory is bad input.
fn check_frame_count(video: &Path, trajectory_frames: usize) -> anyhow::Result<()> {
    let info = eyereplay_extract::probe(video)
        .with_context(|| format!("{}: reading the video", video.display()))?;
    if let Some(f) = info.frames_estimate {
        if f as usize != trajectory_frames {
            bail!(
                "{}: {f} video frames, but its trajectory has {trajectory_frames}",
                video.display()
            );
        }
    }
    Ok(())
}

/// A path as shown in the report: relative to the dataset folder when it is
/// inside it (so reports do not depend on where the dataset lives).
fn shown(dir: &Path, p: &Path) -> String {
    p.strip_prefix(dir).unwrap_or(p).display().to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eye_corners_from_render_geometry_are_ordered_left_to_right() {
        let dir = std::env::temp_dir().join(format!("eyereplay-eval-geom-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("s_identity.json");
        // Image-right eye listed first; its inner corner is on the left.
        std::fs::write(
            &p,
            r#"{"eyes": [
                {"inner_corner_px": [811.0, 403.0], "outer_corner_px": [1094.0, 383.0]},
                {"inner_corner_px": [469.0, 403.0], "outer_corner_px": [186.0, 383.0]}
            ]}"#,
        )
        .unwrap();
        let c = render_eye_corners(&p).unwrap();
        assert_eq!((c[0].0.x, c[0].1.x), (186.0, 469.0));
        assert_eq!((c[1].0.x, c[1].1.x), (811.0, 1094.0));
        std::fs::write(&p, r#"{"eyes": []}"#).unwrap();
        let e = render_eye_corners(&p).unwrap_err().to_string();
        assert!(e.contains("s_identity.json"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn geometry_and_shown_paths() {
        assert_eq!(
            render_geometry_path(Path::new("d/reading/reading_0001.mp4")),
            PathBuf::from("d/reading/reading_0001_identity.json")
        );
        assert_eq!(
            shown(Path::new("/data"), Path::new("/data/reading/r.mp4")),
            "reading/r.mp4"
        );
        assert_eq!(shown(Path::new("/data"), Path::new("/x/r.mp4")), "/x/r.mp4");
    }
}
