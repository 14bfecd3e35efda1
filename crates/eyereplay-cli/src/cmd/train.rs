use super::Bars;
use eyereplay::detect::{Classifier, TrainOptions};
use eyereplay::detector::{train_detector, TrainDetectorOptions, TrainInput};
use std::path::PathBuf;

/// Train the reading detector on generated datasets.
///
/// The detector learns from what it will see in use: the trajectory that
/// 'eyereplay extract' measures on each session's rendered video (cached,
/// so a second run does not extract again), cut into windows that overlap
/// by half, each normalized on its own. The model is 100 bagged decision
/// trees over 14 documented features (docs/DETECTOR.md); every session,
/// scored by trees fitted without it (four folds), calibrates the
/// probabilities (Platt scaling) and fixes the threshold for a stated
/// false-positive rate (--max-fpr). '--classifier logistic' trains the
/// logistic regression of earlier versions, calibrated on a quarter of the
/// sessions held out. Same datasets and seed give the same model file,
/// byte for byte.
#[derive(clap::Args)]
#[command(after_help = "Examples:\n  \
eyereplay train out/default --out reading.model.json\n  \
eyereplay train data/a data/b --out m.json --window-s 30\n  \
# no videos: the session CSVs\n  \
eyereplay train data/ --out m.json --input trajectory\n  \
# when: interviews\n  \
eyereplay train out/interview_train --frame-labels --out interview.json\n\n\
Then: eyereplay detect interview.mp4 --model reading.model.json")]
pub struct Args {
    /// Dataset folders written by 'eyereplay generate' (labels.csv and the
    /// sessions' MP4s), or by 'eyereplay prepare' for --input trajectory
    /// (no videos needed).
    #[arg(required = true)]
    pub datasets: Vec<PathBuf>,
    /// Where to write the model (JSON).
    #[arg(short, long, value_name = "MODEL")]
    pub out: PathBuf,
    /// Window length in seconds, 2 to 600 (10 s is the main size, 30 s the
    /// second).
    #[arg(long, default_value_t = 10.0, value_name = "SECONDS")]
    pub window_s: f64,
    /// What to learn from: 'extracted' (the iris that 'eyereplay extract'
    /// reads from each rendered video, what detect sees), 'trajectory'
    /// (the session CSVs that drove the renderer) or 'drawn' (the drawn
    /// eyes' own position in their apertures, from each video's
    /// _truth.csv: what a perfect extractor would read).
    #[arg(long, value_enum, default_value_t = InputArg::Extracted)]
    pub input: InputArg,
    /// Seed of the validation split and of the trees' bootstrap samples.
    #[arg(long, default_value_t = 1, value_parser = super::values::whole::<u64>)]
    pub seed: u64,
    /// What learns from the 14 features: 'trees' (100 decision trees on
    /// bootstrap samples, a window's score the mean of their leaves'
    /// reading shares) or 'logistic' (one weight each, the model of
    /// earlier versions). The trees find more of the read answers in
    /// generated interviews and call less of real people's other tasks
    /// reading (docs/DETECTOR.md, "Bagged trees").
    #[arg(long, value_enum, default_value_t = ClassifierArg::Trees)]
    pub classifier: ClassifierArg,
    /// L2 regularization weight of the logistic regression (ignored by
    /// the trees).
    #[arg(long, default_value_t = 1.0)]
    pub alpha: f64,
    /// Also train on this many copies of each session with white noise
    /// (levels drawn up to 0.3 x the session's x range): robust to heavy
    /// jitter, less accurate on clean video (docs/DETECTOR.md). At most 100:
    /// each copy adds as many windows as the sessions themselves give.
    #[arg(long, default_value_t = 0, value_name = "N",
          value_parser = clap::value_parser!(u16).range(0..=100))]
    pub noise_copies: u16,
    /// Extraction cache (default: $EYEREPLAY_CACHE, else $XDG_CACHE_HOME/eyereplay, else ~/.cache/eyereplay).
    #[arg(long, value_name = "DIR")]
    pub cache: Option<PathBuf>,
    /// Label each window by the sessions' per-frame `reading` column where
    /// they have one (interview sessions: reading when 80 % of its frames
    /// read, talking when 20 % or fewer, skipped in between), not by the
    /// session's class.
    #[arg(long)]
    pub frame_labels: bool,
    /// Choose the decision threshold so that at most this share of the
    /// validation sessions' not-reading windows is called reading
    #[arg(long, value_name = "RATE", default_value_t = eyereplay::detect::model::DEFAULT_MAX_FPR)]
    pub max_fpr: f64,
}

#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum ClassifierArg {
    Logistic,
    Trees,
}

impl From<ClassifierArg> for Classifier {
    fn from(a: ClassifierArg) -> Self {
        match a {
            ClassifierArg::Logistic => Classifier::LogisticRegression,
            ClassifierArg::Trees => Classifier::BaggedTrees,
        }
    }
}

#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum InputArg {
    Extracted,
    Trajectory,
    Drawn,
}

impl From<InputArg> for TrainInput {
    fn from(a: InputArg) -> Self {
        match a {
            InputArg::Extracted => TrainInput::Extracted,
            InputArg::Trajectory => TrainInput::Trajectory,
            InputArg::Drawn => TrainInput::Drawn,
        }
    }
}

pub fn run(args: Args) -> anyhow::Result<()> {
    // The model is written last: a path it cannot go to is found first.
    let datasets: Vec<&std::path::Path> = args.datasets.iter().map(|d| d.as_path()).collect();
    super::check_json_out(&args.out, "--out", &datasets, &[])?;
    let opts = TrainDetectorOptions {
        window_s: args.window_s,
        input: args.input.into(),
        train: TrainOptions {
            classifier: args.classifier.into(),
            alpha: args.alpha,
            seed: args.seed,
            noise_copies: usize::from(args.noise_copies),
            max_fpr: args.max_fpr,
            ..TrainOptions::default()
        },
        cache: super::cache_dir(args.cache.as_deref())?,
        frame_labels: args.frame_labels,
    };
    let started = std::time::Instant::now();
    let model = train_detector(&args.datasets, &opts, &Bars::default())?;
    model.save(&args.out)?;
    let t = &model.training;
    println!(
        "trained on {} + {} windows of {} s (reading + other), validated on {} + {} from sessions it did not see \
         (other sessions, perhaps of the same people: this says how well it separates these, not other people): \
         AUROC {}, threshold {:.3}",
        t.train_windows_reading,
        t.train_windows_other,
        model.window_s,
        t.validation_windows_reading,
        t.validation_windows_other,
        t.validation_auroc
            .map_or("n/a (too few sessions)".into(), |a| format!("{a:.3}")),
        model.threshold
    );
    // What the threshold and the probabilities are, as measured on those
    // held-out windows (they were in the model file only).
    if let (Some(fpr), Some(tpr)) = (t.validation_fpr, t.validation_tpr) {
        println!(
            "  the threshold is the P(reading) above which a window is called reading, chosen so that at most \
             {:.0} % of not-reading windows are (--max-fpr); on the held-out windows it called {:.1} % of them \
             reading and found {:.1} % of the reading ones",
            100.0 * t.options.max_fpr,
            100.0 * fpr,
            100.0 * tpr
        );
    }
    if let Some(ece) = t.validation_ece {
        println!(
            "  expected calibration error {ece:.3} (0: a window given P(reading) 0.7 reads 70 % of the time; \
             measured on the windows the calibration saw, so 'eyereplay evaluate-localization' measures it on \
             other people)"
        );
    }
    // A handful of windows, or an AUROC at chance, trains a model that
    // only seems to work: written (it is what the data gave), with a word.
    for w in eyereplay::detector::training_warnings(&model) {
        eprintln!("warning: {w}");
    }
    println!(
        "wrote {} in {:.1} s",
        args.out.display(),
        started.elapsed().as_secs_f64()
    );
    Ok(())
}
