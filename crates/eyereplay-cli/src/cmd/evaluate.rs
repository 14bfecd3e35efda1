use anyhow::{bail, Context};
use eyereplay_core::{read_session_csv, CanvasPos};
use eyereplay_eval::dataset::read_truth_norm;
use eyereplay_eval::{
    compare_visual, evaluate_dataset, read_calibration, rendered_video_path, truth_csv_path,
    write_report, EvalConfig, Evaluation, IvtThresholds, VisualRun, VisualSection,
};
use std::path::{Path, PathBuf};

/// Measure a dataset's fidelity: KS tests, Q-Q plots and time-series windows
/// of generated sessions against their source pool, and (when a session has
/// been rendered) the visual mapping fidelity of its video; writes
/// DATASET_DIR/report/index.html (self-contained) and report/metrics.json.
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
            let v = &run.fidelity;
            let f = |o: Option<f64>| o.map_or("n/a".to_string(), |x| format!("{x:.3}"));
            eprintln!(
                "visual fidelity ({}, {} frames): r x {} y {}, amplitude ratio x {} y {}, error mean {:.4} median {:.4} p95 {:.4}",
                run.video,
                v.n_frames,
                f(v.x.r),
                f(v.y.r),
                f(v.x.amplitude_ratio),
                f(v.y.amplitude_ratio),
                v.error.mean,
                v.error.median,
                v.error.p95
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
    let (video, trajectory, truth) = match (&args.video, &args.trajectory) {
        (Some(v), Some(t)) => {
            if !v.is_file() {
                bail!("{}: not found", v.display());
            }
            (v.clone(), t.clone(), None)
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
            (video, dir.join(&session), truth.is_file().then_some(truth))
        }
    };
    let calibration = read_calibration(dir)?;
    let models = args
        .models
        .clone()
        .unwrap_or_else(eyereplay_extract::default_models_dir);
    let missing = eyereplay_extract::missing_files(&models);
    if !missing.is_empty() {
        let reason = format!(
            "not computed: iris models missing in {} ({}); run scripts/models.sh",
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
        let source_n: Vec<[f64; 2]> = input[..n]
            .iter()
            .map(|c| calibration.to_norm([c.x_px, c.y_px]))
            .collect();
        let cmp = compare_visual(&source_n, &t[..n], None)
            .with_context(|| format!("{}: comparing with the source", p.display()))?;
        ev.render_truth = Some((shown(&args.dataset_dir, &p), cmp));
    }
    match compare_video(args, ev, &video, &input, calibration, models) {
        Ok(run) => Ok(VisualSection::Computed(Box::new(run))),
        Err(e) if !explicit => Ok(VisualSection::NotComputed {
            reason: format!(
                "not computed: {}. The eye-crop fallback (iris model on eye crops placed from the \
render's known geometry, for close-ups where the face detector finds no face) is not built yet",
                crate::format_chain(&e)
            ),
        }),
        Err(e) => Err(e),
    }
}

/// Extracts the iris from `video` and compares it with the trajectory
/// mapped back to normalized units.
fn compare_video(
    args: &Args,
    ev: &Evaluation,
    video: &Path,
    input: &[CanvasPos],
    calibration: eyereplay_eval::Calibration,
    models: PathBuf,
) -> anyhow::Result<VisualRun> {
    let n_max = ((args.visual_seconds * ev.fps).round() as usize).min(input.len());
    let opts = eyereplay_extract::ExtractOptions {
        models_dir: models,
        max_duration_s: Some(n_max as f64 / ev.fps),
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
    let n = n_max.min(ext.rows.len());
    anyhow::ensure!(
        n >= 2,
        "{}: only {} frame(s) decoded",
        video.display(),
        ext.rows.len()
    );
    let rendered_n: Vec<[f64; 2]> = ext.rows[..n]
        .iter()
        .map(|r| match r.mean_n() {
            Some((x, y)) if r.valid() => [x, y],
            _ => [f64::NAN, f64::NAN],
        })
        .collect();
    let input = &input[..n];
    let source_n: Vec<[f64; 2]> = input
        .iter()
        .map(|p| calibration.to_norm([p.x_px, p.y_px]))
        .collect();
    let detection_rate = rendered_n.iter().filter(|p| p[0].is_finite()).count() as f64 / n as f64;
    let fidelity = compare_visual(&source_n, &rendered_n, Some((input, ev.canvas)))
        .with_context(|| format!("{}: visual comparison", video.display()))?;
    Ok(VisualRun {
        fidelity,
        source_n,
        rendered_n,
        video: shown(&args.dataset_dir, video),
        eye_locator: "face detector, face mesh and iris model (eyereplay-extract)".into(),
        detection_rate,
    })
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
