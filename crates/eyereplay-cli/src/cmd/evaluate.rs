use eyereplay::{EvalConfig, EvaluateOptions, EvaluateOutcome, VisualChoice};
use eyereplay_eval::{IvtThresholds, VisualSection};
use std::path::PathBuf;

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
# writes data/report/index.html and metrics.json\n  \
eyereplay evaluate data/\n  \
eyereplay evaluate data/ --json | jq .distribution.reading.speed\n  \
eyereplay evaluate data/ --visual-session reading/reading_0003.csv \\\n      \
--visual-seconds 120\n  \
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
    /// A KS D at or below this counts as a pass in the report (0 to 1).
    #[arg(long, default_value_t = 0.15, value_parser = super::values::probability)]
    pub d_max: f64,
    /// Canvas pixels per degree of visual angle, if the viewing geometry is
    /// known; adds saccade amplitudes in degrees.
    #[arg(long, value_name = "PX", value_parser = super::values::positive)]
    pub px_per_deg: Option<f64>,
    /// Skip the visual fidelity section.
    #[arg(long, conflicts_with_all = ["video", "trajectory", "visual_session"])]
    pub no_visual: bool,
    /// Session whose rendered video is compared (path relative to the
    /// dataset, as in labels.csv); default: the first rendered reading session.
    #[arg(long, value_name = "CSV")]
    pub visual_session: Option<String>,
    /// Any rendered video to judge (with --trajectory), e.g. another
    /// simulator's, instead of a session of the dataset.
    #[arg(long, requires = "trajectory", conflicts_with = "visual_session")]
    pub video: Option<PathBuf>,
    /// The frame,x,y canvas trajectory that drove --video; mapped back to
    /// normalized iris units with metadata.json's calibration.
    #[arg(long, requires = "video")]
    pub trajectory: Option<PathBuf>,
    /// Compare only the first this many seconds of the video (the paper: 120).
    #[arg(long, default_value_t = 120.0, value_name = "SECONDS")]
    pub visual_seconds: f64,
    /// Folder of the iris models (default: $EYEREPLAY_MODELS, else the Python package's, else $EYEREPLAY_CACHE/models, else .cache/models up from the current folder).
    #[arg(long, value_name = "DIR")]
    pub models: Option<PathBuf>,
    /// Also read every rendered session back whole and add a table of
    /// them to the report (one extraction of every video).
    #[arg(long)]
    pub read_back_all: bool,
    /// Without --read-back-all: read back the first N sessions of each
    /// class whole, for that table (0: no table).
    #[arg(
        long,
        default_value_t = 1,
        value_name = "N",
        conflicts_with = "read_back_all",
        value_parser = super::values::whole::<usize>
    )]
    pub read_back: usize,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let visual = match (
        args.no_visual,
        &args.video,
        &args.trajectory,
        &args.visual_session,
    ) {
        (true, ..) => VisualChoice::Skip,
        (_, Some(video), Some(trajectory), _) => VisualChoice::Video {
            video: video.clone(),
            trajectory: trajectory.clone(),
        },
        (_, _, _, Some(s)) => VisualChoice::Session(s.clone()),
        _ => VisualChoice::Auto,
    };
    let opts = EvaluateOptions {
        config: EvalConfig {
            thresholds: IvtThresholds {
                fixation_below_px_per_frame: args.fixation_below,
                saccade_above_px_per_frame: args.saccade_above,
                ..IvtThresholds::default()
            },
            window_s: args.window_s,
            d_max: args.d_max,
            px_per_deg: args.px_per_deg,
            ..EvalConfig::default()
        },
        visual,
        visual_seconds: args.visual_seconds,
        models: args.models.clone(),
        read_back_all: args.read_back_all,
        read_back_per_class: args.read_back,
    };
    let outcome =
        eyereplay::evaluate_with_progress(&args.dataset_dir, &opts, &super::Bars::default())?;
    super::work_done();
    print_outcome(&outcome, args.json);
    Ok(())
}

/// KS per class and metric, the visual fidelity line and where the report
/// is, on stderr; with `json`, metrics.json on stdout.
pub fn print_outcome(o: &EvaluateOutcome, json: bool) {
    let ev = &o.evaluation;
    let d_max = ev.config.d_max;
    for c in &ev.classes {
        for m in &c.comparisons {
            match &m.ks {
                Some(k) => eprintln!(
                    "{:<13} {:<18} D = {:.4}  p = {:.3e}  (n = {} / {})  {}",
                    c.class.name(),
                    m.metric.key(),
                    k.d,
                    k.p,
                    m.n_source,
                    m.n_generated,
                    if k.d <= d_max {
                        format!("pass (D <= {d_max})")
                    } else {
                        format!("FAIL (D > {d_max})")
                    }
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
    // Not `eprint!`, which panics on a closed standard error (main.rs).
    let _ = std::io::Write::write_all(
        &mut std::io::stderr(),
        eyereplay_eval::behaviour_table(&ev.behaviour).as_bytes(),
    );
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
    // The page's summary: the checks it marks, and which fail (the exit
    // status stays 0: a report that fails a check is still a report).
    eprintln!("{}", eyereplay_eval::report::checks(ev).line());
    eprintln!("report: {}", o.html.display());
    eprintln!("metrics: {}", o.metrics_path.display());
    if json {
        print!("{}", o.metrics_json);
    }
}
