use anyhow::Context;
use eyereplay_eval::{evaluate_dataset, write_report, EvalConfig, IvtThresholds};
use std::path::PathBuf;

/// Measure a dataset's fidelity: KS tests, Q-Q plots and time-series windows
/// of generated sessions against their source pool; writes
/// DATASET_DIR/report/index.html (self-contained) and report/metrics.json.
#[derive(clap::Args)]
#[command(after_help = "Examples:\n  \
eyereplay evaluate data/                 # writes data/report/index.html and metrics.json\n  \
eyereplay evaluate data/ --json | jq .distribution.reading.speed")]
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
}

pub fn run(args: Args) -> anyhow::Result<()> {
    anyhow::ensure!(
        args.fixation_below > 0.0 && args.saccade_above >= args.fixation_below,
        "thresholds: need 0 < --fixation-below <= --saccade-above (got {} and {})",
        args.fixation_below,
        args.saccade_above
    );
    anyhow::ensure!(args.window_s > 0.0, "--window-s must be positive");
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
    let ev = evaluate_dataset(&args.dataset_dir, &cfg).context("evaluate")?;
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
    if let eyereplay_eval::VisualSection::NotComputed { .. } = &ev.visual {
        eprintln!("visual fidelity: not computed (see the report)");
    }
    eprintln!("report: {}", paths.html.display());
    eprintln!("metrics: {}", paths.metrics.display());
    if args.json {
        print!("{metrics}");
    }
    Ok(())
}
