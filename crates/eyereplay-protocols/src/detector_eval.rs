//! Does a detector trained only on synthetic video work on real
//! recordings? The protocol that answers it (`eyereplay evaluate-detector`).
//!
//! A protocol file names real recordings (each with its person, its class
//! and its task), folds (synthetic training configs per render mode, and
//! the real recordings held out for testing) and render modes (how a real
//! eye-tracker recording is rendered to be read back, as a user would).
//! For each window length, mode and fold, the command generates the
//! training datasets, trains the feature model on what the extractor reads
//! from their videos, and scores the fold's held-out recordings:
//!
//! - `rendered`: the real eye-tracker recordings rendered in the mode and
//!   read back by the extractor (the same path as the training data);
//! - `noise_k`: the real recordings at 25 fps with white noise of `k` times
//!   the recording's 5-95 % x range per frame (webcam-like degradation);
//! - webcam: real talking-face videos through `eyereplay extract`
//!   (negatives only: the false-positive rate at the model's threshold).
//!
//! Next to each: the 1D-CNN trained on the same synthetic windows, the
//! zero-training rule (forward-run fraction) on the same windows, and a
//! ceiling trained on the real windows themselves, leaving out the pair of
//! people it is tested on. AUROC is computed per reader within one model
//! and averaged ([`eyereplay_detect::pairwise_auroc`]); intervals come from
//! a bootstrap over people.

use eyereplay::detector::{dataset_tracks, extract_csv_track, TrainInput};
use eyereplay::{extract_cached, generate, plan_config, Error, GenerateOptions, Result};
use eyereplay_core::{GazeClass, Progress};
use eyereplay_detect::calibration::{expected_calibration_error, reliability, ReliabilityBin};
use eyereplay_detect::metrics::{
    balanced_threshold, pairwise_auroc, rate_at, roc_curve, PairAuroc,
};
use eyereplay_detect::{
    rule_score, windows, AurocCi, DetectorModel, Example, Track, TrainOptions, Window, WindowSpec,
    FPS,
};
use eyereplay_prepare::{ClassConfig, DatasetConfig};
use eyereplay_sources::SourceSpec;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

fn d_seed() -> u64 {
    1
}
fn d_windows() -> Vec<f64> {
    vec![10.0, 30.0]
}
fn d_noise() -> Vec<f64> {
    vec![0.0, 0.1, 0.2, 0.3]
}
fn d_reps() -> usize {
    2000
}
fn d_copies() -> usize {
    eyereplay_detect::model::AUGMENT_COPIES
}

/// The protocol file.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Protocol {
    #[serde(default = "d_seed")]
    pub seed: u64,
    /// Window lengths to evaluate (s); the first is the main one.
    #[serde(default = "d_windows")]
    pub window_s: Vec<f64>,
    /// Noise levels k of the `noise_k` conditions.
    #[serde(default = "d_noise")]
    pub noise_levels: Vec<f64>,
    #[serde(default = "d_reps")]
    pub bootstrap_replicates: usize,
    /// Noisy copies of each training session (`eyereplay train` makes
    /// [`eyereplay_detect::model::AUGMENT_COPIES`]); 0 trains on the
    /// rendered sessions alone.
    #[serde(default = "d_copies")]
    pub training_noise_copies: usize,
    /// What learns from the features: `bagged_trees` (the default, as
    /// `eyereplay train`'s) or `logistic_regression`.
    #[serde(default)]
    pub classifier: eyereplay_detect::Classifier,
    /// Render modes by name.
    pub modes: BTreeMap<String, ModeSpec>,
    pub recording: Vec<RecordingSpec>,
    pub fold: Vec<FoldSpec>,
    #[serde(skip)]
    pub base_dir: PathBuf,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModeSpec {
    /// A dataset config whose settings (render mode, session length,
    /// smoothing...) render the real eye-tracker recordings; its classes
    /// are replaced by the recording.
    pub render: PathBuf,
}

/// One real recording.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RecordingSpec {
    pub name: String,
    /// Who was recorded: the bootstrap's unit.
    pub person: String,
    pub reading: bool,
    /// What the person was doing (for the report).
    pub task: String,
    /// A task so easy to tell from reading (holding fixation) that results
    /// are also reported without it.
    #[serde(default)]
    pub trivial: bool,
    /// The recording, as a dataset source; a `video` source is a webcam
    /// clip, scored through `eyereplay extract` (negatives only).
    pub source: SourceSpec,
}

impl RecordingSpec {
    pub fn is_webcam(&self) -> bool {
        matches!(self.source, SourceSpec::Video { .. })
    }
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FoldSpec {
    pub name: String,
    /// Training dataset config per render mode.
    pub train: BTreeMap<String, PathBuf>,
    /// Names of the recordings held out for this fold.
    pub test: Vec<String>,
}

impl Protocol {
    /// Loads and checks a protocol: every file there, names known, and no
    /// test recording among its fold's training sources.
    pub fn load(path: &Path) -> Result<Self> {
        // Said as what was expected, not the OS's "Is a directory".
        const WANTED: &str = "evaluate-detector takes a protocol file (TOML), such as examples/detector/protocol.toml";
        if path.is_dir() {
            return Err(Error::input(path, format!("a folder: {WANTED}")));
        }
        if !path.exists() {
            return Err(Error::input(path, format!("no such file: {WANTED}")));
        }
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        let mut p: Protocol = toml::from_str(&text).map_err(|e| {
            let is_toml = path.extension().is_some_and(|x| x == "toml");
            let why = eyereplay_prepare::describe_toml_error(&text, &e);
            Error::input(
                path,
                if is_toml {
                    why
                } else {
                    format!("not a protocol file ({why}): {WANTED}")
                },
            )
        })?;
        p.base_dir = path
            .parent()
            .filter(|d| !d.as_os_str().is_empty())
            .map_or_else(|| PathBuf::from("."), Path::to_path_buf);
        p.check(path)?;
        Ok(p)
    }

    pub fn resolve(&self, p: &Path) -> PathBuf {
        if p.is_relative() {
            self.base_dir.join(p)
        } else {
            p.to_path_buf()
        }
    }

    fn check(&self, path: &Path) -> Result<()> {
        let bad = |m: String| Err(Error::input(path, m));
        if self.window_s.is_empty() || self.window_s.iter().any(|w| w.is_nan() || *w < 2.0) {
            return bad("window_s must list lengths of at least 2 s".into());
        }
        if self
            .noise_levels
            .iter()
            .any(|k| !(*k >= 0.0 && k.is_finite()))
        {
            return bad("noise_levels must be numbers >= 0".into());
        }
        if self.bootstrap_replicates == 0 {
            return bad("bootstrap_replicates must be at least 1".into());
        }
        let mut names = std::collections::BTreeSet::new();
        for r in &self.recording {
            if !names.insert(r.name.as_str()) {
                return bad(format!("recording '{}' is named twice", r.name));
            }
            let file = self.resolve(r.source.path());
            if !file.is_file() {
                return Err(Error::input(
                    file,
                    format!(
                        "recording '{}' not found (scripts/detector-data.sh fetches the bundled ones)",
                        r.name
                    ),
                ));
            }
            // A video that does not open would fail only when its turn
            // comes, after the training data is drawn: open it now (the
            // container and stream only, no decoding).
            if r.is_webcam() {
                eyereplay::extract::probe(&file).map_err(|e| {
                    // The extractor's message names the file too.
                    let why = strip_path(&e.to_string(), &file);
                    Error::input(&file, format!("recording '{}': {why}", r.name))
                })?;
            }
            if r.is_webcam() && r.reading {
                return bad(format!(
                    "recording '{}': a webcam video is scored as a negative only; set reading = false",
                    r.name
                ));
            }
        }
        let mut templates = Vec::new();
        for (m, spec) in &self.modes {
            let f = self.resolve(&spec.render);
            if !f.is_file() {
                return Err(Error::input(f, format!("modes.{m}.render: no such config")));
            }
            // Its [render] table too: a bad one stopped the run only when
            // the real recordings' turn came, after the training data.
            let cfg = DatasetConfig::load(&f)?;
            eyereplay::render_table(&cfg, &f)?;
            templates.push(cfg);
        }
        // Every eye-tracker recording parses as its format says, read as
        // the first mode reads it (a wrong `format` was found only after
        // the training data was drawn and half the recordings rendered).
        if let Some(cfg) = templates.first() {
            for r in self.recording.iter().filter(|r| !r.is_webcam()) {
                let mut source = r.source.clone();
                *source.path_mut() = self.resolve(r.source.path());
                eyereplay_sources::read_source(&source, &cfg.read).map_err(|e| {
                    Error::input(
                        source.path(),
                        format!(
                            "recording '{}': {}",
                            r.name,
                            strip_path(&e.to_string(), source.path())
                        ),
                    )
                })?;
            }
        }
        let mut folds = std::collections::BTreeSet::new();
        for fold in &self.fold {
            if !folds.insert(fold.name.as_str()) {
                return bad(format!(
                    "fold '{}' is named twice (each fold's models and results are kept under its name)",
                    fold.name
                ));
            }
            for t in &fold.test {
                if !names.contains(t.as_str()) {
                    return bad(format!(
                        "fold '{}': unknown test recording '{t}'",
                        fold.name
                    ));
                }
            }
            for (mode, cfg) in &fold.train {
                if !self.modes.contains_key(mode) {
                    return bad(format!(
                        "fold '{}': training mode '{mode}' is not under [modes]",
                        fold.name
                    ));
                }
                let cfg_path = self.resolve(cfg);
                let config = DatasetConfig::load(&cfg_path)?;
                // Each fold's [render] table before the first fold's
                // training data is drawn.
                eyereplay::render_table(&config, &cfg_path)?;
                let train_files: Vec<PathBuf> =
                    config.source_paths().iter().map(|p| canonical(p)).collect();
                for t in &fold.test {
                    let r = self.recording_named(t).expect("checked above");
                    if train_files.contains(&canonical(&self.resolve(r.source.path()))) {
                        return Err(Error::input(
                            cfg_path,
                            format!(
                                "fold '{}': its test recording '{t}' is also a training source: the test would not be held out",
                                fold.name
                            ),
                        ));
                    }
                }
            }
        }
        if self.fold.is_empty() {
            return bad("no [[fold]]".into());
        }
        if self.modes.is_empty() {
            return bad("no [modes]: name at least one render mode".into());
        }
        Ok(())
    }

    pub fn recording_named(&self, name: &str) -> Option<&RecordingSpec> {
        self.recording.iter().find(|r| r.name == name)
    }
}

fn canonical(p: &Path) -> PathBuf {
    p.canonicalize().unwrap_or_else(|_| p.to_path_buf())
}

/// A recording as the dataset pipeline prepared it (stages 2-5: blink
/// filter, smoothing, 25 fps, its pieces concatenated, exactly as the
/// rendered sessions were cut from it), mapped back from canvas px to
/// normalized iris units with the dataset's calibration: the same
/// representation as the training data, without the render.
fn pool_track(dir: &Path, reading: bool) -> Result<Track> {
    let meta = eyereplay_dataset::read_metadata(dir)?;
    let d = &meta.dataset;
    let cal = d
        .calibration
        .or_else(|| d.sources.first().map(|s| s.calibration))
        .ok_or_else(|| Error::input(dir.join("metadata.json"), "no calibration"))?;
    let pool =
        eyereplay_dataset::read_pool(&dir.join(eyereplay_dataset::pool_file(class_of(reading))))?;
    Ok(Track::new(
        pool.iter()
            .flat_map(|seg| seg.points.iter())
            .map(|p| {
                let n = cal.canvas_to_norm(eyereplay_core::CanvasPos {
                    x_px: p[0],
                    y_px: p[1],
                });
                [n.nx, n.ny]
            })
            .collect(),
    ))
}

/// The `noise_k` degradation of one recording's tracks, seeded by the
/// protocol seed, the recording and `k`.
fn with_noise(tracks: &[Track], k: f64, seed: u64, name: &str) -> Vec<Track> {
    tracks
        .iter()
        .enumerate()
        .map(|(i, t)| {
            let s = eyereplay_detect::window::name_seed(seed ^ k.to_bits(), &format!("{name}#{i}"));
            eyereplay_detect::window::with_white_noise(t, k, s)
        })
        .collect()
}

/// Windows of every track.
fn all_windows(tracks: &[Track], spec: WindowSpec) -> Vec<Window> {
    tracks.iter().flat_map(|t| windows(t, spec)).collect()
}

/// A real window's score and its features (for the ceiling).
type ScoredFeatures = (RealWindow, [f64; eyereplay_detect::FEATURE_COUNT]);

/// A scored window of a real recording, with the rule's score beside it.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct RealWindow {
    pub fold: String,
    pub recording: String,
    pub person: String,
    pub reading: bool,
    pub trivial: bool,
    pub model: f64,
    pub rule: f64,
    /// The 1D-CNN's probability.
    pub cnn: f64,
}

/// AUROC of the model, the rule and the ceiling on one set of windows.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ConditionResult {
    pub window_s: f64,
    pub mode: String,
    /// `rendered` or `noise_<k>`.
    pub condition: String,
    pub model: Option<AurocCi>,
    /// The 1D-CNN trained on the same synthetic windows.
    pub cnn: Option<AurocCi>,
    pub rule: Option<AurocCi>,
    /// Trained on the real windows, leaving one person out.
    pub ceiling: Option<AurocCi>,
    /// The same three without the trivial (fixation-task) negatives.
    pub model_nontrivial: Option<AurocCi>,
    pub cnn_nontrivial: Option<AurocCi>,
    pub rule_nontrivial: Option<AurocCi>,
    pub ceiling_nontrivial: Option<AurocCi>,
    /// Reading windows called reading, and other windows called reading,
    /// at each fold model's own threshold.
    pub true_positive_rate: f64,
    pub false_positive_rate: f64,
    /// Whether the feature model's probabilities mean what they say on
    /// these real windows (every fold's together; probabilities are
    /// calibrated on each fold's synthetic validation sessions): 10 bins.
    pub reliability: Vec<ReliabilityBin>,
    pub expected_calibration_error: f64,
    /// The false-positive rate each fold's threshold was chosen for.
    pub target_false_positive_rate: f64,
    /// Mean model probability per recording (and fold).
    pub per_recording: Vec<RecordingScore>,
    #[serde(skip)]
    pub roc_model: Vec<(String, Vec<(f64, f64)>)>,
    #[serde(skip)]
    pub roc_rule: Vec<(f64, f64)>,
    #[serde(skip)]
    pub roc_ceiling: Vec<(f64, f64)>,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct RecordingScore {
    pub fold: String,
    pub recording: String,
    pub reading: bool,
    pub windows: usize,
    pub mean_probability: f64,
    pub called_reading: f64,
}

/// False positives on one real talking-face video.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct WebcamResult {
    pub window_s: f64,
    pub mode: String,
    pub fold: String,
    pub recording: String,
    pub windows: usize,
    /// Share of windows the model calls reading at its threshold.
    pub false_positive_rate: f64,
    /// The same for the rule at its threshold fixed on the synthetic
    /// training windows.
    pub rule_false_positive_rate: f64,
    /// The same for the 1D-CNN.
    pub cnn_false_positive_rate: f64,
}

/// A fold model's training, for the report.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FoldModel {
    pub window_s: f64,
    pub mode: String,
    pub fold: String,
    pub train_windows: usize,
    pub validation_auroc: Option<f64>,
    pub threshold: f64,
    pub rule_threshold: f64,
    /// The 1D-CNN's threshold: balanced accuracy on its training windows.
    pub cnn_threshold: f64,
    pub weights: Vec<(String, f64)>,
}

/// Everything the protocol measured.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct DetectorEvaluation {
    pub protocol: String,
    pub seed: u64,
    /// The feature model's classifier.
    #[serde(default = "eyereplay_detect::Classifier::before_the_choice")]
    pub classifier: eyereplay_detect::Classifier,
    pub recordings: Vec<RecordingInfo>,
    pub models: Vec<FoldModel>,
    pub conditions: Vec<ConditionResult>,
    pub webcam: Vec<WebcamResult>,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct RecordingInfo {
    pub name: String,
    pub person: String,
    pub reading: bool,
    pub task: String,
    pub trivial: bool,
    pub webcam: bool,
    pub duration_s: f64,
    pub folds: Vec<String>,
}

fn class_of(reading: bool) -> GazeClass {
    if reading {
        GazeClass::Reading
    } else {
        GazeClass::Conversation
    }
}

/// Generates a dataset from `config` into `out` (resumable), without its
/// evaluation report.
fn generate_into(
    config: DatasetConfig,
    label: &Path,
    out: &Path,
    cache: &Path,
    progress: &dyn Progress,
) -> Result<()> {
    let job = plan_config(config, label, None, cache)?;
    let opts = GenerateOptions {
        out: out.to_path_buf(),
        shard: None,
        cache: Some(cache.to_path_buf()),
        evaluate: None,
    };
    generate(&job, &opts, progress)?;
    Ok(())
}

/// Runs the protocol into `out`: the generated datasets under `train/` and
/// `real/`; the results are written by [`crate::evaluate_detector`].
pub fn run_protocol(
    protocol_path: &Path,
    out: &Path,
    cache: &Path,
    classifier: Option<eyereplay_detect::Classifier>,
    progress: &dyn Progress,
) -> Result<DetectorEvaluation> {
    let mut p = Protocol::load(protocol_path)?;
    if let Some(c) = classifier {
        p.classifier = c;
    }
    std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
    let used: Vec<&RecordingSpec> = p
        .recording
        .iter()
        .filter(|r| p.fold.iter().any(|f| f.test.contains(&r.name)))
        .collect();

    // 1. Synthetic training data, per fold and mode.
    let mut train_dirs: BTreeMap<(String, String), PathBuf> = BTreeMap::new();
    for fold in &p.fold {
        for (mode, cfg) in &fold.train {
            let cfg_path = p.resolve(cfg);
            let dir = out.join("train").join(&fold.name).join(mode);
            progress.info(&format!(
                "fold {}, {mode}: generating the training data from {} into {}",
                fold.name,
                cfg_path.display(),
                dir.display()
            ));
            generate_into(
                DatasetConfig::load(&cfg_path)?,
                &cfg_path,
                &dir,
                cache,
                progress,
            )?;
            train_dirs.insert((fold.name.clone(), mode.clone()), dir);
        }
    }

    // 2. Real recordings: clean tracks, rendered-and-extracted tracks per
    //    mode, webcam tracks.
    let mut clean: BTreeMap<String, Vec<Track>> = BTreeMap::new();
    let mut rendered: BTreeMap<(String, String), Vec<Track>> = BTreeMap::new();
    let mut infos = Vec::new();
    for r in &used {
        if r.is_webcam() {
            let video = p.resolve(r.source.path());
            let csv = extract_cached(&[video], cache, progress)?.remove(0);
            clean.insert(r.name.clone(), vec![extract_csv_track(&csv)?]);
        }
        for (mode, spec) in p.modes.iter().filter(|_| !r.is_webcam()) {
            let template = p.resolve(&spec.render);
            let mut cfg = DatasetConfig::load(&template)?;
            let mut source = r.source.clone();
            *source.path_mut() = canonical(&p.resolve(r.source.path()));
            // The recording's gaze time, its gap-free pieces at 25 fps.
            let frames: usize = eyereplay_sources::read_source(&source, &cfg.read)?
                .iter()
                .flat_map(|rec| rec.segments.iter())
                .map(|seg| {
                    let v: Vec<&eyereplay_core::Sample<eyereplay_core::NormPos>> =
                        seg.samples().iter().collect();
                    eyereplay::detector::resample_samples(&v).len()
                })
                .sum();
            // As many whole sessions as the recording fills (at least one).
            let sessions = (frames / cfg.session_frames.max(1)).max(1);
            cfg.classes = BTreeMap::from([(
                class_of(r.reading),
                ClassConfig {
                    sessions,
                    speed_scale: None,
                    sources: vec![source],
                    generators: vec![],
                },
            )]);
            let dir = out.join("real").join(mode).join(&r.name);
            progress.info(&format!(
                "{}: rendering {sessions} session(s) in mode {mode} to read back",
                r.name
            ));
            generate_into(cfg, &template, &dir, cache, progress)?;
            if !clean.contains_key(&r.name) {
                clean.insert(r.name.clone(), vec![pool_track(&dir, r.reading)?]);
            }
            let t = dataset_tracks(&[dir], TrainInput::Extracted, cache, progress)?;
            rendered.insert(
                (r.name.clone(), mode.clone()),
                t.into_iter().map(|l| l.track).collect(),
            );
        }
        let frames: usize = clean[&r.name].iter().map(Track::len).sum();
        infos.push(RecordingInfo {
            name: r.name.clone(),
            person: r.person.clone(),
            reading: r.reading,
            task: r.task.clone(),
            trivial: r.trivial,
            webcam: r.is_webcam(),
            duration_s: frames as f64 / FPS,
            folds: p
                .fold
                .iter()
                .filter(|f| f.test.contains(&r.name))
                .map(|f| f.name.clone())
                .collect(),
        });
    }

    let mut models = Vec::new();
    let mut conditions = Vec::new();
    let mut webcam = Vec::new();
    let mut train_tracks: BTreeMap<(String, String), Vec<eyereplay::detector::LabeledTrack>> =
        BTreeMap::new();
    for (key, dir) in &train_dirs {
        train_tracks.insert(
            key.clone(),
            dataset_tracks(
                std::slice::from_ref(dir),
                TrainInput::Extracted,
                cache,
                progress,
            )?,
        );
    }
    let mut conds: Vec<String> = vec!["rendered".into()];
    conds.extend(p.noise_levels.iter().map(|k| format!("noise_{k}")));
    for &w in &p.window_s {
        let score_spec = WindowSpec::seconds(w);
        for mode in p.modes.keys() {
            // Real windows per condition, over all folds.
            let mut per_cond: BTreeMap<String, Vec<RealWindow>> = BTreeMap::new();
            let mut feats: BTreeMap<String, Vec<ScoredFeatures>> = BTreeMap::new();
            // Webcam windows: scored for false positives; the ceiling also
            // trains on them (more kinds of non-reading), never tests.
            let mut webcam_rows: Vec<ScoredFeatures> = Vec::new();
            for fold in &p.fold {
                let Some(tt) = train_tracks.get(&(fold.name.clone(), mode.clone())) else {
                    continue;
                };
                let train_opts = TrainOptions {
                    classifier: p.classifier,
                    seed: p.seed,
                    noise_copies: p.training_noise_copies,
                    ..TrainOptions::default()
                };
                let examples = eyereplay::detector::training_examples(tt, w, &train_opts);
                let model = eyereplay_detect::train(&examples, w, train_opts, vec![], "extracted")?;
                let (rs, rl): (Vec<f64>, Vec<bool>) = tt
                    .iter()
                    .flat_map(|t| {
                        windows(&t.track, WindowSpec::half_overlap(w))
                            .into_iter()
                            .map(|win| (rule_score(&win), t.reading))
                            .collect::<Vec<_>>()
                    })
                    .unzip();
                let rule_threshold = balanced_threshold(&rs, &rl);
                // The 1D-CNN on the same sessions' windows (no noisy copies).
                let (cnn_w, cnn_l): (Vec<Window>, Vec<bool>) = tt
                    .iter()
                    .flat_map(|t| {
                        windows(&t.track, WindowSpec::half_overlap(w))
                            .into_iter()
                            .map(|win| (win, t.reading))
                            .collect::<Vec<_>>()
                    })
                    .unzip();
                progress.info(&format!(
                    "fold {}, {mode}, {w} s: training the 1D-CNN on {} windows",
                    fold.name,
                    cnn_w.len()
                ));
                let cnn = eyereplay_detect::cnn::train_cnn(
                    &cnn_w,
                    &cnn_l,
                    eyereplay_detect::cnn::CnnOptions {
                        seed: p.seed,
                        ..Default::default()
                    },
                )?;
                let cnn_train = cnn.probabilities(&cnn_w.iter().collect::<Vec<_>>())?;
                let cnn_threshold = balanced_threshold(&cnn_train, &cnn_l);
                models.push(FoldModel {
                    window_s: w,
                    mode: mode.clone(),
                    fold: fold.name.clone(),
                    train_windows: examples.len(),
                    validation_auroc: model.training.validation_auroc,
                    threshold: model.threshold,
                    rule_threshold,
                    cnn_threshold,
                    weights: model
                        .features
                        .iter()
                        .cloned()
                        .zip(model.weights.iter().copied())
                        .collect(),
                });
                for name in &fold.test {
                    let r = p.recording_named(name).expect("checked");
                    let score =
                        |wins: Vec<Window>, m: &DetectorModel| -> Result<Vec<ScoredFeatures>> {
                            let refs: Vec<&Window> = wins.iter().collect();
                            let cnn_p = cnn.probabilities(&refs)?;
                            Ok(wins
                                .iter()
                                .zip(cnn_p)
                                .map(|(win, cnn_p)| {
                                    let f = eyereplay_detect::features(win);
                                    (
                                        RealWindow {
                                            fold: fold.name.clone(),
                                            recording: r.name.clone(),
                                            person: r.person.clone(),
                                            reading: r.reading,
                                            trivial: r.trivial,
                                            model: m.probability_of(&f),
                                            rule: rule_score(win),
                                            cnn: cnn_p,
                                        },
                                        f,
                                    )
                                })
                                .collect())
                        };
                    if r.is_webcam() {
                        let scored = score(all_windows(&clean[name], score_spec), &model)?;
                        if p.fold.iter().position(|f| f.test.contains(name))
                            == p.fold.iter().position(|f| f.name == fold.name)
                        {
                            webcam_rows.extend(scored.iter().cloned());
                        }
                        let ms: Vec<f64> = scored.iter().map(|s| s.0.model).collect();
                        let rs: Vec<f64> = scored.iter().map(|s| s.0.rule).collect();
                        let cs: Vec<f64> = scored.iter().map(|s| s.0.cnn).collect();
                        webcam.push(WebcamResult {
                            window_s: w,
                            mode: mode.clone(),
                            fold: fold.name.clone(),
                            recording: name.clone(),
                            windows: ms.len(),
                            false_positive_rate: rate_at(&ms, model.threshold),
                            rule_false_positive_rate: rate_at(&rs, rule_threshold),
                            cnn_false_positive_rate: rate_at(&cs, cnn_threshold),
                        });
                        continue;
                    }
                    for c in &conds {
                        let tracks = if c == "rendered" {
                            rendered[&(name.clone(), mode.clone())].clone()
                        } else {
                            let k: f64 = c["noise_".len()..].parse().expect("own format");
                            with_noise(&clean[name], k, p.seed, name)
                        };
                        let scored = score(all_windows(&tracks, score_spec), &model)?;
                        per_cond
                            .entry(c.clone())
                            .or_default()
                            .extend(scored.iter().map(|s| s.0.clone()));
                        // The ceiling sees each real window once (not once per fold).
                        if p.fold.iter().position(|f| f.test.contains(name))
                            == p.fold.iter().position(|f| f.name == fold.name)
                        {
                            feats.entry(c.clone()).or_default().extend(scored);
                        }
                    }
                }
            }
            for c in &conds {
                let rows = per_cond.remove(c).unwrap_or_default();
                let thresholds: BTreeMap<String, f64> = models
                    .iter()
                    .filter(|m| m.window_s == w && &m.mode == mode)
                    .map(|m| (m.fold.clone(), m.threshold))
                    .collect();
                conditions.push(condition_result(
                    &p,
                    (w, mode, c),
                    &rows,
                    feats.remove(c).unwrap_or_default(),
                    &webcam_rows,
                    &thresholds,
                ));
            }
        }
    }
    let eval = DetectorEvaluation {
        protocol: protocol_path
            .file_name()
            .map_or_else(String::new, |n| n.to_string_lossy().into_owned()),
        seed: p.seed,
        classifier: p.classifier,
        recordings: infos,
        models,
        conditions,
        webcam,
    };
    Ok(eval)
}

/// Persons of `rows` by class, sorted.
fn persons(rows: &[&RealWindow], reading: bool) -> Vec<String> {
    let mut v: Vec<String> = rows
        .iter()
        .filter(|r| r.reading == reading)
        .map(|r| r.person.clone())
        .collect();
    v.sort();
    v.dedup();
    v
}

/// Pair AUROCs (reader against each non-reader, within the fold that
/// scored the reader) of a score.
fn pairs_of(
    rows: &[&RealWindow],
    score: impl Fn(&RealWindow) -> f64,
    skip_trivial: bool,
) -> Vec<PairAuroc> {
    let mut out = Vec::new();
    for reader in persons(rows, true) {
        let mine: Vec<&&RealWindow> = rows
            .iter()
            .filter(|r| r.reading && r.person == reader)
            .collect();
        let Some(fold) = mine.first().map(|r| r.fold.clone()) else {
            continue;
        };
        for other in persons(rows, false) {
            let theirs: Vec<&&RealWindow> = rows
                .iter()
                .filter(|r| {
                    !r.reading
                        && r.person == other
                        && r.fold == fold
                        && !(skip_trivial && r.trivial)
                })
                .collect();
            if theirs.is_empty() {
                continue;
            }
            let s: Vec<f64> = mine.iter().chain(&theirs).map(|r| score(r)).collect();
            let l: Vec<bool> = mine.iter().chain(&theirs).map(|r| r.reading).collect();
            if let Some(a) = eyereplay_detect::auroc(&s, &l) {
                out.push(PairAuroc {
                    reader: reader.clone(),
                    other,
                    auroc: a,
                    other_windows: theirs.len(),
                });
            }
        }
    }
    out
}

/// The ceiling's pair AUROCs: for each reader and non-reader, a logistic
/// regression trained on every other real window (the webcam windows
/// included, as more non-reading) scores the two: leave one pair of people
/// out.
fn ceiling_pairs(
    rows: &[ScoredFeatures],
    extra_negatives: &[ScoredFeatures],
    seed: u64,
    skip_trivial: bool,
) -> (Vec<PairAuroc>, Vec<(f64, f64)>) {
    let refs: Vec<&RealWindow> = rows.iter().map(|r| &r.0).collect();
    let mut out = Vec::new();
    let (mut all_s, mut all_l) = (Vec::new(), Vec::new());
    for reader in persons(&refs, true) {
        for other in persons(&refs, false) {
            let held = |r: &RealWindow| r.person == reader || r.person == other;
            let train: Vec<Example> = rows
                .iter()
                .chain(extra_negatives)
                .filter(|r| !held(&r.0))
                .map(|r| Example {
                    features: r.1,
                    reading: r.0.reading,
                    group: r.0.recording.clone(),
                })
                .collect();
            let Ok(m) = eyereplay_detect::train(
                &train,
                0.0,
                TrainOptions {
                    // A reference, the model of the protocol's first
                    // version: kept so its figures stay comparable.
                    classifier: eyereplay_detect::Classifier::LogisticRegression,
                    validation_fraction: 0.0,
                    noise_copies: 0,
                    seed,
                    ..TrainOptions::default()
                },
                vec![],
                "real",
            ) else {
                continue; // the rest holds one class only
            };
            let test: Vec<&ScoredFeatures> = rows
                .iter()
                .filter(|r| held(&r.0) && !(skip_trivial && r.0.trivial))
                .collect();
            let s: Vec<f64> = test.iter().map(|r| m.probability_of(&r.1)).collect();
            let l: Vec<bool> = test.iter().map(|r| r.0.reading).collect();
            if let Some(a) = eyereplay_detect::auroc(&s, &l) {
                out.push(PairAuroc {
                    reader: reader.clone(),
                    other: other.clone(),
                    auroc: a,
                    other_windows: l.iter().filter(|&&x| !x).count(),
                });
                all_s.extend(s);
                all_l.extend(l);
            }
        }
    }
    (out, roc_curve(&all_s, &all_l))
}

/// `(window_s, mode, condition)` of a [`ConditionResult`].
type ConditionKey<'a> = (f64, &'a str, &'a str);

fn condition_result(
    p: &Protocol,
    (w, mode, condition): ConditionKey,
    rows: &[RealWindow],
    feats: Vec<ScoredFeatures>,
    webcam_rows: &[ScoredFeatures],
    thresholds: &BTreeMap<String, f64>,
) -> ConditionResult {
    let reps = p.bootstrap_replicates;
    let all: Vec<&RealWindow> = rows.iter().collect();
    let ci = |pairs: Vec<PairAuroc>| pairwise_auroc(&pairs, reps, 0.95, p.seed);
    let (ceil, roc_ceiling) = ceiling_pairs(&feats, webcam_rows, p.seed, false);
    let (ceil_nt, _) = ceiling_pairs(&feats, webcam_rows, p.seed, true);
    let called = |r: &RealWindow| r.model >= thresholds.get(&r.fold).copied().unwrap_or(0.5);
    let rate = |reading: bool| {
        let v: Vec<&&RealWindow> = all.iter().filter(|r| r.reading == reading).collect();
        v.iter().filter(|r| called(r)).count() as f64 / v.len().max(1) as f64
    };
    let mut per_recording = Vec::new();
    let mut keys: Vec<(String, String)> = rows
        .iter()
        .map(|r| (r.fold.clone(), r.recording.clone()))
        .collect();
    keys.sort();
    keys.dedup();
    for (fold, rec) in keys {
        let v: Vec<&RealWindow> = rows
            .iter()
            .filter(|r| r.fold == fold && r.recording == rec)
            .collect();
        per_recording.push(RecordingScore {
            reading: v[0].reading,
            windows: v.len(),
            mean_probability: v.iter().map(|r| r.model).sum::<f64>() / v.len() as f64,
            called_reading: v.iter().filter(|r| called(r)).count() as f64 / v.len() as f64,
            fold,
            recording: rec,
        });
    }
    // ROC of each fold's model on its own windows (scores of two models
    // are not comparable), and of the rule on fold A's windows.
    let mut roc_model = Vec::new();
    for fold in &p.fold {
        let v: Vec<&&RealWindow> = all.iter().filter(|r| r.fold == fold.name).collect();
        let s: Vec<f64> = v.iter().map(|r| r.model).collect();
        let l: Vec<bool> = v.iter().map(|r| r.reading).collect();
        if let Some(a) = eyereplay_detect::auroc(&s, &l) {
            roc_model.push((format!("fold {} {a:.2}", fold.name), roc_curve(&s, &l)));
        }
    }
    let reliability = reliability(
        &all.iter().map(|r| r.model).collect::<Vec<_>>(),
        &all.iter().map(|r| r.reading).collect::<Vec<_>>(),
        10,
    );
    let first = p.fold.first().map(|f| f.name.clone()).unwrap_or_default();
    let v: Vec<&&RealWindow> = all.iter().filter(|r| r.fold == first).collect();
    let roc_rule = roc_curve(
        &v.iter().map(|r| r.rule).collect::<Vec<_>>(),
        &v.iter().map(|r| r.reading).collect::<Vec<_>>(),
    );
    ConditionResult {
        window_s: w,
        mode: mode.to_string(),
        condition: condition.to_string(),
        model: ci(pairs_of(&all, |r| r.model, false)),
        cnn: ci(pairs_of(&all, |r| r.cnn, false)),
        rule: ci(pairs_of(&all, |r| r.rule, false)),
        ceiling: ci(ceil),
        model_nontrivial: ci(pairs_of(&all, |r| r.model, true)),
        cnn_nontrivial: ci(pairs_of(&all, |r| r.cnn, true)),
        rule_nontrivial: ci(pairs_of(&all, |r| r.rule, true)),
        ceiling_nontrivial: ci(ceil_nt),
        true_positive_rate: rate(true),
        false_positive_rate: rate(false),
        reliability: reliability.clone(),
        expected_calibration_error: expected_calibration_error(&reliability),
        target_false_positive_rate: eyereplay_detect::model::DEFAULT_MAX_FPR,
        per_recording,
        roc_model,
        roc_rule,
        roc_ceiling,
    }
}

/// An error's message without the file name it starts with (the caller
/// names the file once).
fn strip_path(message: &str, path: &Path) -> String {
    message
        .strip_prefix(&format!("{}: ", path.display()))
        .unwrap_or(message)
        .to_string()
}
