use super::Bars;
use eyereplay_protocols::evaluate_detector;
use std::path::PathBuf;

/// Does a detector trained on synthetic video work on real recordings?
///
/// Runs the protocol file: generates each fold's synthetic training
/// datasets (per render mode), renders the real eye-tracker test recordings
/// in each mode and reads them back, trains the detector (feature model
/// and 1D-CNN) per fold, mode and window length, and scores the held-out
/// real recordings beside the zero-training rule and a ceiling trained on
/// real data (leaving out the pair of people it is tested on). Writes
/// OUT/index.html and OUT/detector_eval.json. Resumable: the
/// generated datasets are kept under OUT/train and OUT/real, and a rerun
/// skips what is finished. A long job: examples/detector/protocol.toml
/// takes about 25-40 min on 2 cores. Its real
/// recordings are fetched once by scripts/detector-data.sh, a script of
/// the source checkout (a missing one is named before any work).
#[derive(clap::Args)]
#[command(after_help = "Examples:\n  \
scripts/detector-data.sh        # the real test recordings (once)\n  \
eyereplay evaluate-detector examples/detector/protocol.toml \\\n      \
--out out/detector-eval\n\n\
docs/DETECTOR.md explains the protocol file and how to read the report.")]
pub struct Args {
    /// The protocol (TOML): recordings, folds, render modes.
    pub protocol: PathBuf,
    /// Output folder.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Extraction cache (default: $EYEREPLAY_CACHE, else $XDG_CACHE_HOME/eyereplay, else ~/.cache/eyereplay).
    #[arg(long, value_name = "DIR")]
    pub cache: Option<PathBuf>,
    /// The feature model's classifier, in place of the protocol's
    /// `classifier` (as 'eyereplay train --classifier').
    #[arg(long, value_enum, value_name = "CLASSIFIER")]
    pub classifier: Option<super::train::ClassifierArg>,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    super::check_folder_arg(&args.out, "--out")?;
    let cache = super::cache_dir(args.cache.as_deref())?;
    let ev = evaluate_detector(
        &args.protocol,
        &args.out,
        &cache,
        args.classifier.map(Into::into),
        &Bars::default(),
    )?;
    let f = |a: &Option<eyereplay::detect::AurocCi>| {
        a.as_ref().map_or("  n/a ".into(), |a| {
            format!("{:.3} [{:.2}, {:.2}]", a.auroc, a.low, a.high)
        })
    };
    println!(
        "{:>6} {:<10} {:<12} {:<22} {:<22} {:<22} {:<22}",
        "window",
        "training",
        "test data",
        "synthetic (features)",
        "synthetic (1D-CNN)",
        "zero-training rule",
        "real-trained ceiling"
    );
    for c in &ev.conditions {
        println!(
            "{:>5}s {:<10} {:<12} {:<22} {:<22} {:<22} {:<22}",
            c.window_s,
            c.mode,
            c.condition,
            f(&c.model),
            f(&c.cnn),
            f(&c.rule),
            f(&c.ceiling)
        );
    }
    for w in &ev.webcam {
        println!(
            "{:>5}s {:<10} webcam {:<14} fold {:<3} FPR {:.2} ({} windows; 1D-CNN {:.2}, rule {:.2})",
            w.window_s,
            w.mode,
            w.recording,
            w.fold,
            w.false_positive_rate,
            w.windows,
            w.cnn_false_positive_rate,
            w.rule_false_positive_rate
        );
    }
    println!("wrote {}", args.out.join("index.html").display());
    Ok(())
}
