use eyereplay_protocols::evaluate_localization;
use std::path::PathBuf;

/// When does someone read? Scores reading segments against known ones.
///
/// On every session of DATASET with a per-frame `reading` column (made by
/// the behaviour models' interview scenarios), finds reading segments with
/// the detector MODEL, once per way of turning window scores into frames
/// (the mean of overlapping windows; the same smoothed by a two-state
/// hidden Markov model), and prints per method: segment F1 at IoU 0.5,
/// the median onset error, and the share of not-reading time called
/// reading. The sessions' trajectories are scored (no video needed).
#[derive(clap::Args)]
#[command(after_help = "Examples:\n  \
eyereplay prepare --config examples/localize_train.toml --out out/localize_train\n  \
eyereplay train out/localize_train --input trajectory --frame-labels --window-s 6 --out out/interview.json\n  \
eyereplay prepare --config examples/localize.toml --out out/localize        # other people\n  \
eyereplay evaluate-localization out/localize --model out/interview.json")]
pub struct Args {
    /// A dataset folder with interview sessions (`eyereplay prepare` or `generate`).
    pub dataset: PathBuf,
    /// The detector (`eyereplay train`).
    #[arg(long, value_name = "FILE")]
    pub model: PathBuf,
    /// Cut segments where the per-frame probability of reading reaches this.
    #[arg(long, default_value_t = eyereplay::detect::localize::SEGMENT_THRESHOLD)]
    pub threshold: f64,
    /// Also write every number here as JSON.
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let ev = evaluate_localization(&args.dataset, &args.model, args.threshold)?;
    println!(
        "{} sessions, {:.0} min, {} reading segments; model {}, segments cut at {:.3}",
        ev.sessions,
        ev.seconds / 60.0,
        ev.reading_segments,
        ev.model,
        ev.threshold
    );
    println!(
        "{:<12} {:>6} {:>9} {:>7} {:>6} {:>10} {:>14} {:>14}",
        "method", "found", "matched", "F1", "P", "R", "onset med s", "false reading"
    );
    for m in &ev.methods {
        println!(
            "{:<12} {:>6} {:>9} {:>7.3} {:>6.3} {:>10.3} {:>14} {:>13.1}%",
            format!("{:?}", m.method),
            m.segments.found,
            m.segments.matched,
            m.segments.f1,
            m.segments.precision,
            m.segments.recall,
            m.onset_error_median_s
                .map_or("n/a".to_string(), |v| format!("{v:.1}")),
            100.0 * m.false_reading_fraction
        );
    }
    if let Some(path) = &args.json {
        let mut text = serde_json::to_string_pretty(&ev)?;
        text.push('\n');
        eyereplay_core::atomic_write(path, text.as_bytes())?;
    }
    Ok(())
}
