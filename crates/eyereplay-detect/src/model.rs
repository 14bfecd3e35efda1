//! The feature model: logistic regression (linfa-logistic, L2) over the
//! standardized [`features`](mod@crate::features), or bagged decision trees
//! over them ([`crate::forest`]), with calibrated probabilities and the
//! decision threshold fixed on validation sessions the fit did not see.
//! Saved as one JSON file that says what it was trained on.

use crate::calibration::{
    expected_calibration_error, reliability, sigmoid, threshold_for_fpr, Platt,
};
use crate::features::{features, FEATURE_COUNT, FEATURE_NAMES};
use crate::forest::Forest;
use crate::metrics::{auroc, rate_at};
use crate::window::Window;
use crate::DetectError;
use linfa::prelude::*;
use linfa_logistic::LogisticRegression;
use ndarray::{Array1, Array2};
use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// What a model file says it is.
pub const MODEL_FORMAT: &str = "eyereplay-detector";
pub const MODEL_VERSION: u32 = 1;
/// The shortest window a model may score: two seconds hold a few
/// fixations and saccades, fewer give the features nothing to measure.
pub const MIN_WINDOW_S: f64 = 2.0;
/// The longest window: 10 minutes (the detector's are 6-30 s; an
/// interview's answer is shorter than this).
pub const MAX_WINDOW_S: f64 = 600.0;

/// One training window: its features, its label, and the session it came
/// from (validation is held out by session, never by window, since
/// overlapping windows of one session share frames).
#[derive(Clone, Debug, PartialEq)]
pub struct Example {
    pub features: [f64; FEATURE_COUNT],
    pub reading: bool,
    pub group: String,
}

impl Example {
    pub fn of(w: &Window, reading: bool, group: &str) -> Self {
        Example {
            features: features(w),
            reading,
            group: group.to_string(),
        }
    }
}

/// Noisy copies of each training session that `--noise-copies` asks for
/// (webcam-like degradation, see [`crate::window::with_white_noise`]),
/// each with a noise level drawn uniformly from `0..AUGMENT_MAX_K`. Off by
/// default: on real recordings rendered and read back they cost more than
/// they give (docs/DETECTOR.md, "Noise augmentation"), but they make the
/// model hold up under heavy white noise.
pub const AUGMENT_COPIES: usize = 0;
pub const AUGMENT_MAX_K: f64 = 0.3;

/// The training windows of one session: its own, and those of
/// `copies` noisy copies (levels drawn from the seed and the group).
pub fn session_examples(
    track: &crate::window::Track,
    reading: bool,
    group: &str,
    spec: crate::window::WindowSpec,
    copies: usize,
    seed: u64,
) -> Vec<Example> {
    use rand::Rng;
    let mut out: Vec<Example> = crate::window::windows(track, spec)
        .iter()
        .map(|w| Example::of(w, reading, group))
        .collect();
    let mut rng = ChaCha8Rng::seed_from_u64(crate::window::name_seed(seed, group));
    for _ in 0..copies {
        let k = rng.gen_range(0.0..AUGMENT_MAX_K);
        let noisy = crate::window::with_white_noise(track, k, rng.gen());
        out.extend(
            crate::window::windows(&noisy, spec)
                .iter()
                .map(|w| Example::of(w, reading, group)),
        );
    }
    out
}

/// What learns from the features.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Classifier {
    /// One weight per standardized feature (linfa-logistic, L2 `alpha`):
    /// the only model until 29 Nov 2026.
    LogisticRegression,
    /// [`crate::forest::TREES`] decision trees on bootstrap samples, the
    /// calibration cross-fitted ([`CROSS_FIT_FOLDS`]): the default.
    #[default]
    BaggedTrees,
}

impl Classifier {
    /// What a model file or protocol written before the choice existed
    /// used.
    pub fn before_the_choice() -> Self {
        Classifier::LogisticRegression
    }

    /// For people: "a logistic regression", "100 bagged decision trees".
    pub fn describe(self) -> String {
        match self {
            Classifier::LogisticRegression => "a logistic regression".into(),
            Classifier::BaggedTrees => {
                format!("{} bagged decision trees", crate::forest::TREES)
            }
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrainOptions {
    /// The model (models trained before the choice existed are logistic).
    #[serde(default = "Classifier::before_the_choice")]
    pub classifier: Classifier,
    /// L2 weight on the coefficients (linfa's `alpha`: the penalty is
    /// `alpha / 2 * |w|^2` next to the summed log-loss).
    pub alpha: f64,
    /// Share of sessions of each class held out to fix the threshold.
    pub validation_fraction: f64,
    /// Noisy copies of each session ([`session_examples`]).
    pub noise_copies: usize,
    pub seed: u64,
    /// The decision threshold is the lowest at which at most this share of
    /// the validation sessions' not-reading windows is called reading.
    #[serde(default = "default_max_fpr")]
    pub max_fpr: f64,
}

/// The false-positive rate the threshold is chosen for, unless told.
pub const DEFAULT_MAX_FPR: f64 = 0.05;

fn default_max_fpr() -> f64 {
    DEFAULT_MAX_FPR
}

impl Default for TrainOptions {
    fn default() -> Self {
        TrainOptions {
            classifier: Classifier::default(),
            alpha: 1.0,
            validation_fraction: 0.25,
            noise_copies: AUGMENT_COPIES,
            seed: 1,
            max_fpr: DEFAULT_MAX_FPR,
        }
    }
}

/// How a model came about, for the user and for the report.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrainingInfo {
    pub datasets: Vec<String>,
    /// `extracted` (what `eyereplay extract` reads from each video) or
    /// `trajectory` (the session CSVs that drove the renderer).
    pub input: String,
    pub options: TrainOptions,
    pub train_windows_reading: usize,
    pub train_windows_other: usize,
    pub validation_windows_reading: usize,
    pub validation_windows_other: usize,
    /// AUROC on the held-out validation sessions (synthetic).
    pub validation_auroc: Option<f64>,
    /// At the threshold, on the validation windows: the share of
    /// not-reading windows called reading, and of reading windows found.
    #[serde(default)]
    pub validation_fpr: Option<f64>,
    #[serde(default)]
    pub validation_tpr: Option<f64>,
    /// Expected calibration error of the (calibrated) probabilities on the
    /// validation windows, 10 bins; in-sample for the calibration, so
    /// `eyereplay evaluate-localization` measures it again on other people.
    #[serde(default)]
    pub validation_ece: Option<f64>,
}

/// A trained detector.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DetectorModel {
    pub format: String,
    pub version: u32,
    pub kind: String,
    pub window_s: f64,
    pub features: Vec<String>,
    /// Standardization: `z = (f - mean) / std`.
    pub mean: Vec<f64>,
    pub std: Vec<f64>,
    pub weights: Vec<f64>,
    pub intercept: f64,
    /// A window with probability at or above this is called reading:
    /// chosen on the validation sessions for a false-positive rate of at
    /// most `training.options.max_fpr`.
    pub threshold: f64,
    /// Platt scaling of the regression's log-odds, fitted on the
    /// validation sessions (absent in models trained before it existed).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub calibration: Option<Platt>,
    /// The trees of a `bagged_trees` model (its `weights` are then empty).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub forest: Option<Forest>,
    pub training: TrainingInfo,
}

impl DetectorModel {
    /// Probability that the window shows reading.
    pub fn probability(&self, w: &Window) -> f64 {
        self.probability_of(&features(w))
    }

    pub fn probability_of(&self, f: &[f64; FEATURE_COUNT]) -> f64 {
        let z = self.log_odds_of(f);
        match &self.calibration {
            Some(c) => c.apply(z),
            None => sigmoid(z),
        }
    }

    /// The model's log-odds of reading, before calibration: the
    /// regression's, or the trees' ([`Forest::log_odds`]).
    pub fn log_odds_of(&self, f: &[f64; FEATURE_COUNT]) -> f64 {
        if let Some(forest) = &self.forest {
            return forest.log_odds(f);
        }
        (0..FEATURE_COUNT)
            .map(|k| self.weights[k] * (f[k] - self.mean[k]) / self.std[k])
            .sum::<f64>()
            + self.intercept
    }

    pub fn save(&self, path: &Path) -> Result<(), DetectError> {
        let mut text = serde_json::to_string_pretty(self).expect("model serializes");
        text.push('\n');
        Ok(eyereplay_core::atomic_write(path, text.as_bytes())?)
    }

    pub fn load(path: &Path) -> Result<Self, DetectError> {
        let bytes = std::fs::read(path).map_err(|e| DetectError::io(path, e))?;
        let Ok(text) = String::from_utf8(bytes) else {
            return Err(DetectError::file(
                path,
                "not a detector model (not text; 'eyereplay train' writes one as JSON)",
            ));
        };
        Self::parse(&text, path)
    }

    /// A model from the text of its JSON file, checked as [`Self::load`]
    /// checks a file (errors name `path`): for a model built into a
    /// program, such as the command's default.
    pub fn parse(text: &str, path: &Path) -> Result<Self, DetectError> {
        // Another JSON file (a dataset's metadata.json, a detection) is
        // told apart from a damaged model by its missing `format` key.
        if let Ok(v) = serde_json::from_str::<serde_json::Value>(text) {
            match v.get("format") {
                Some(f) if f.as_str() == Some(MODEL_FORMAT) => {}
                Some(f) => {
                    return Err(DetectError::file(
                        path,
                        format!("not a detector model (format {f}, not \"{MODEL_FORMAT}\")"),
                    ))
                }
                None => {
                    return Err(DetectError::file(
                        path,
                        format!(
                            "not a detector model (a JSON file without \"format\": \"{MODEL_FORMAT}\"; \
                             'eyereplay train' writes one)"
                        ),
                    ))
                }
            }
        }
        // serde names the line and column of a value of the wrong type, not
        // its field: the top-level numbers are named here.
        if let Ok(serde_json::Value::Object(fields)) = serde_json::from_str(text) {
            for key in ["version", "window_s", "threshold"] {
                if let Some(v) = fields.get(key).filter(|v| !v.is_number()) {
                    return Err(DetectError::file(
                        path,
                        format!("{key} must be a number, got {v}; train it again"),
                    ));
                }
            }
        }
        let m: DetectorModel = serde_json::from_str(text)
            .map_err(|e| DetectError::file(path, format!("not a detector model: {e}")))?;
        if m.version != MODEL_VERSION {
            return Err(DetectError::file(
                path,
                format!(
                    "detector model version {}, but this eyereplay reads version {MODEL_VERSION}; train it again",
                    m.version
                ),
            ));
        }
        let kind_problem = match (m.kind.as_str(), m.forest.is_some()) {
            ("bagged_trees", true) | ("logistic_regression", false) => None,
            ("bagged_trees", false) => {
                Some("a 'bagged_trees' model without its `forest`".to_string())
            }
            ("logistic_regression", true) => {
                Some("a 'logistic_regression' model with a `forest`".to_string())
            }
            (k, _) => Some(format!(
                "model kind '{k}' is not 'bagged_trees' or 'logistic_regression'"
            )),
        };
        if let Some(problem) = kind_problem {
            return Err(DetectError::file(
                path,
                format!("{problem}; train it again"),
            ));
        }
        if !(MIN_WINDOW_S..=MAX_WINDOW_S).contains(&m.window_s) {
            return Err(DetectError::file(
                path,
                format!(
                    "window_s must be {MIN_WINDOW_S} to {MAX_WINDOW_S} s, got {}",
                    eyereplay_core::show_number(m.window_s)
                ),
            ));
        }
        // Numbers that no training writes: each would turn every
        // probability into 0 or 1, or NaN, without a word.
        let finite = |v: &[f64]| v.iter().all(|x| x.is_finite() && x.abs() <= 1e6);
        let numbers_problem = if !finite(&m.mean) || !finite(&m.std) || !finite(&m.weights) {
            Some("its feature means, spreads or weights are not finite numbers of a sane size")
        } else if m.std.iter().any(|s| *s <= 0.0) {
            Some("a feature's spread (std) is not above 0")
        } else if !finite(&[m.intercept]) {
            Some("its intercept is not a finite number of a sane size")
        } else if m
            .calibration
            .as_ref()
            .is_some_and(|c| !finite(&[c.slope, c.intercept]))
        {
            Some("its calibration's slope or intercept is not a finite number of a sane size")
        } else {
            None
        };
        if let Some(problem) = numbers_problem {
            return Err(DetectError::file(
                path,
                format!("{problem}; train it again"),
            ));
        }
        if !(0.0..=1.0).contains(&m.threshold) {
            return Err(DetectError::file(
                path,
                format!(
                    "threshold must be a probability (0 to 1), got {}",
                    m.threshold
                ),
            ));
        }
        let names: Vec<&str> = m.features.iter().map(String::as_str).collect();
        if let Some(problem) = m.forest.as_ref().and_then(|f| f.malformed()) {
            return Err(DetectError::file(
                path,
                format!("{problem}; train it again"),
            ));
        }
        if names != FEATURE_NAMES
            || m.mean.len() != FEATURE_COUNT
            || m.std.len() != FEATURE_COUNT
            || (m.forest.is_none() && m.weights.len() != FEATURE_COUNT)
        {
            return Err(DetectError::file(
                path,
                "its features are not this eyereplay's; train it again",
            ));
        }
        Ok(m)
    }
}

/// The groups (sessions) with windows of `class`, sorted, then shuffled by
/// `rng`: the order the validation split and the folds deal from.
fn shuffled_groups<'a>(examples: &'a [Example], class: bool, rng: &mut ChaCha8Rng) -> Vec<&'a str> {
    let mut groups: Vec<&str> = Vec::new();
    for e in examples.iter().filter(|e| e.reading == class) {
        if !groups.contains(&e.group.as_str()) {
            groups.push(&e.group);
        }
    }
    groups.sort_unstable();
    groups.shuffle(rng);
    groups
}

/// Splits examples into (train, validation) by group, per class, with the
/// seed; every class keeps at least one group for training.
pub fn split_by_group(examples: &[Example], fraction: f64, seed: u64) -> (Vec<usize>, Vec<usize>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut valid_groups: Vec<&str> = Vec::new();
    for class in [true, false] {
        let groups = shuffled_groups(examples, class, &mut rng);
        let k =
            ((groups.len() as f64 * fraction).round() as usize).min(groups.len().saturating_sub(1));
        valid_groups.extend(&groups[..k]);
    }
    let (mut train, mut valid) = (Vec::new(), Vec::new());
    for (i, e) in examples.iter().enumerate() {
        if valid_groups.contains(&e.group.as_str()) {
            valid.push(i);
        } else {
            train.push(i);
        }
    }
    (train, valid)
}

/// Folds of the bagged trees' cross-fitting. A quarter of the sessions
/// held out once, as the regression does, left the trees without the
/// sessions that mattered on one seed in three (validation AUROC 0.83
/// against 1.0; docs/DETECTOR.md, "Bagged trees"): each session is held
/// out once across four folds, and the trees kept are fitted on all.
pub const CROSS_FIT_FOLDS: usize = 4;

/// Each example's fold, `0..k`: the sessions of each class shuffled with
/// the seed and dealt round, so a session's windows share a fold.
pub fn group_folds(examples: &[Example], k: usize, seed: u64) -> Vec<usize> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut fold_of: Vec<(&str, usize)> = Vec::new();
    for class in [true, false] {
        let groups = shuffled_groups(examples, class, &mut rng);
        fold_of.extend(
            groups
                .into_iter()
                .enumerate()
                .map(|(j, g)| (g, j % k.max(1))),
        );
    }
    examples
        .iter()
        .map(|e| {
            fold_of
                .iter()
                .find(|(g, _)| *g == e.group)
                .map_or(0, |&(_, f)| f)
        })
        .collect()
}

/// Where a model's validation scores come from.
enum Validation {
    /// Windows of sessions the fit did not see, scored by the model.
    HeldOut(Vec<usize>),
    /// Every window's log-odds from trees fitted without its session.
    CrossFitted(Vec<f64>),
}

/// The features and labels of the examples at `idx`.
fn features_and_labels(
    examples: &[Example],
    idx: &[usize],
) -> (Vec<[f64; FEATURE_COUNT]>, Vec<bool>) {
    (
        idx.iter().map(|&i| examples[i].features).collect(),
        idx.iter().map(|&i| examples[i].reading).collect(),
    )
}

/// Each window's log-odds from trees fitted on the other folds' sessions
/// ([`CROSS_FIT_FOLDS`]), so that calibrating on them is calibrating on
/// sessions the trees did not see.
fn cross_fitted_log_odds(examples: &[Example], seed: u64) -> Result<Vec<f64>, DetectError> {
    let folds = group_folds(examples, CROSS_FIT_FOLDS, seed);
    let mut log_odds = vec![0.0; examples.len()];
    for k in 0..CROSS_FIT_FOLDS {
        let (held, fit): (Vec<usize>, Vec<usize>) =
            (0..examples.len()).partition(|&i| folds[i] == k);
        if held.is_empty() {
            continue;
        }
        let (x, y) = features_and_labels(examples, &fit);
        let forest = Forest::fit(&x, &y, seed.wrapping_add(1 + k as u64))?;
        for i in held {
            log_odds[i] = forest.log_odds(&examples[i].features);
        }
    }
    Ok(log_odds)
}

/// Fits the model on the training sessions and fixes its threshold on the
/// validation sessions.
pub fn train(
    examples: &[Example],
    window_s: f64,
    opts: TrainOptions,
    datasets: Vec<String>,
    input: &str,
) -> Result<DetectorModel, DetectError> {
    let count = |idx: &[usize], c: bool| idx.iter().filter(|&&i| examples[i].reading == c).count();
    let all: Vec<usize> = (0..examples.len()).collect();
    if count(&all, true) == 0 || count(&all, false) == 0 {
        return Err(DetectError::Train(format!(
            "training needs windows of both classes; found {} reading and {} other windows of {window_s} s with enough gaze (at most {:.0} % of a window's frames may be missing)",
            count(&all, true),
            count(&all, false),
            100.0 * crate::window::MAX_MISSING_FRACTION
        )));
    }
    // What the fit sees, and how its calibration and threshold are
    // validated: the regression on a quarter of the sessions held out,
    // the trees on every session scored by trees fitted without it.
    let (fit_idx, validation) = match opts.classifier {
        Classifier::LogisticRegression => {
            let (train_idx, valid_idx) =
                split_by_group(examples, opts.validation_fraction, opts.seed);
            (train_idx, Validation::HeldOut(valid_idx))
        }
        Classifier::BaggedTrees => (
            all.clone(),
            Validation::CrossFitted(cross_fitted_log_odds(examples, opts.seed)?),
        ),
    };
    let mut mean = vec![0.0; FEATURE_COUNT];
    let mut std = vec![0.0; FEATURE_COUNT];
    for k in 0..FEATURE_COUNT {
        let v: Vec<f64> = fit_idx.iter().map(|&i| examples[i].features[k]).collect();
        mean[k] = eyereplay_signal::stats::mean(&v).unwrap_or(0.0);
        let s = eyereplay_signal::stats::std_pop(&v).unwrap_or(0.0);
        // A feature that never varies in training carries nothing; a unit
        // scale keeps it harmless instead of dividing by zero.
        std[k] = if s > 1e-12 { s } else { 1.0 };
    }
    let (kind, weights, intercept, forest) = match opts.classifier {
        Classifier::LogisticRegression => {
            let mut x = Array2::<f64>::zeros((fit_idx.len(), FEATURE_COUNT));
            for (r, &i) in fit_idx.iter().enumerate() {
                for k in 0..FEATURE_COUNT {
                    x[[r, k]] = (examples[i].features[k] - mean[k]) / std[k];
                }
            }
            let y: Array1<usize> = fit_idx
                .iter()
                .map(|&i| usize::from(examples[i].reading))
                .collect();
            let fitted = LogisticRegression::default()
                .alpha(opts.alpha)
                .max_iterations(500)
                .fit(&Dataset::new(x, y))
                .map_err(|e| DetectError::Train(format!("logistic regression: {e}")))?;
            // linfa calls the more numerous class positive (and the first
            // seen on a tie), whatever its value: turn the fit round when
            // that is not reading, so the model always gives P(reading).
            let sign = if fitted.labels().pos.class == 1 {
                1.0
            } else {
                -1.0
            };
            (
                "logistic_regression",
                fitted.params().iter().map(|w| sign * w).collect(),
                sign * fitted.intercept(),
                None,
            )
        }
        Classifier::BaggedTrees => {
            let (x, y) = features_and_labels(examples, &all);
            (
                "bagged_trees",
                Vec::new(),
                0.0,
                Some(Forest::fit(&x, &y, opts.seed)?),
            )
        }
    };
    let mut model = DetectorModel {
        format: MODEL_FORMAT.into(),
        version: MODEL_VERSION,
        kind: kind.into(),
        window_s,
        features: FEATURE_NAMES.iter().map(|s| s.to_string()).collect(),
        mean,
        std,
        weights,
        intercept,
        threshold: 0.5,
        calibration: None,
        forest,
        training: TrainingInfo {
            datasets,
            input: input.into(),
            options: opts,
            train_windows_reading: count(&fit_idx, true),
            train_windows_other: count(&fit_idx, false),
            validation_windows_reading: 0,
            validation_windows_other: 0,
            validation_auroc: None,
            validation_fpr: None,
            validation_tpr: None,
            validation_ece: None,
        },
    };
    let (valid_idx, log_odds): (Vec<usize>, Vec<f64>) = match validation {
        Validation::HeldOut(idx) => {
            let z = idx
                .iter()
                .map(|&i| model.log_odds_of(&examples[i].features))
                .collect();
            (idx, z)
        }
        Validation::CrossFitted(z) => (all, z),
    };
    model.training.validation_windows_reading = count(&valid_idx, true);
    model.training.validation_windows_other = count(&valid_idx, false);
    let labels: Vec<bool> = valid_idx.iter().map(|&i| examples[i].reading).collect();
    if labels.iter().any(|&l| l) && labels.iter().any(|&l| !l) {
        model.calibration = Platt::fit(&log_odds, &labels);
        let scores: Vec<f64> = log_odds
            .iter()
            .map(|&z| match &model.calibration {
                Some(c) => c.apply(z),
                None => sigmoid(z),
            })
            .collect();
        let of_class = |c: bool| -> Vec<f64> {
            scores
                .iter()
                .zip(&labels)
                .filter(|(_, &l)| l == c)
                .map(|(&p, _)| p)
                .collect()
        };
        let negatives = of_class(false);
        model.threshold = threshold_for_fpr(&negatives, opts.max_fpr);
        let fpr = rate_at(&negatives, model.threshold);
        let tpr = rate_at(&of_class(true), model.threshold);
        model.training.validation_auroc = auroc(&scores, &labels);
        model.training.validation_fpr = Some(fpr);
        model.training.validation_tpr = Some(tpr);
        model.training.validation_ece = Some(expected_calibration_error(&reliability(
            &scores, &labels, 10,
        )));
    }
    Ok(model)
}

/// A model trained on a toy set whose first feature tells the classes
/// apart, for other modules' tests.
#[cfg(test)]
pub(crate) fn toy_model(window_s: f64) -> DetectorModel {
    let logistic = tests::logistic;
    let ex = tests::examples();
    train(&ex, window_s, logistic(), vec![], "toy").unwrap()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The logistic regression's options (the default is the trees).
    pub(crate) fn logistic() -> TrainOptions {
        TrainOptions {
            classifier: Classifier::LogisticRegression,
            ..TrainOptions::default()
        }
    }

    /// Examples whose first feature separates the classes with some overlap.
    pub(crate) fn examples() -> Vec<Example> {
        let mut out = Vec::new();
        for g in 0..8 {
            for k in 0..20 {
                let reading = g % 2 == 0;
                let mut f = [0.0; FEATURE_COUNT];
                let centre = if reading { 1.0 } else { -1.0 };
                f[0] = centre + ((k * 7 + g * 3) % 11) as f64 / 5.0 - 1.0;
                f[1] = ((k * 5 + g) % 13) as f64; // noise
                out.push(Example {
                    features: f,
                    reading,
                    group: format!("s{g}"),
                });
            }
        }
        out
    }

    #[test]
    fn training_learns_the_separating_feature_and_is_deterministic() {
        let ex = examples();
        let m = train(&ex, 10.0, logistic(), vec![], "trajectory").unwrap();
        assert!(m.weights[0] > 1.0, "{:?}", m.weights);
        assert!(m.weights[0].abs() > 5.0 * m.weights[1].abs());
        assert!(m.training.validation_auroc.unwrap() > 0.9);
        // The threshold keeps the validation false-positive rate within
        // the stated one, and the probabilities are calibrated there.
        assert!(m.training.validation_fpr.unwrap() <= DEFAULT_MAX_FPR);
        assert!(m.calibration.is_some());
        assert!(m.training.validation_ece.unwrap() < 0.2);
        let again = train(&ex, 10.0, logistic(), vec![], "trajectory").unwrap();
        assert_eq!(
            serde_json::to_string(&m).unwrap(),
            serde_json::to_string(&again).unwrap()
        );
        // Validation holds out whole sessions: 2 of 4 per class at 0.25 -> 1 each.
        assert_eq!(m.training.validation_windows_reading, 20);
        assert_eq!(m.training.validation_windows_other, 20);
    }

    /// The bagged trees: every session scored by trees that did not see
    /// it (four folds of one session per class here), the trees kept
    /// fitted on all; deterministic, and a saved model loads back.
    #[test]
    fn bagged_trees_are_cross_fitted_deterministic_and_load_back() {
        let ex = examples();
        let opts = TrainOptions::default();
        assert_eq!(opts.classifier, Classifier::BaggedTrees);
        let m = train(&ex, 10.0, opts, vec![], "t").unwrap();
        assert_eq!(m.kind, "bagged_trees");
        assert!(m.weights.is_empty() && m.forest.is_some());
        // Every window is both trained on and validated on, held out.
        assert_eq!(m.training.train_windows_reading, 80);
        assert_eq!(m.training.validation_windows_reading, 80);
        assert!(
            m.training.validation_auroc.unwrap() > 0.9,
            "{:?}",
            m.training
        );
        assert!(m.training.validation_fpr.unwrap() <= DEFAULT_MAX_FPR);
        let mut f = [0.0; FEATURE_COUNT];
        f[0] = 2.0;
        assert!(m.probability_of(&f) > 0.5);
        f[0] = -2.0;
        assert!(m.probability_of(&f) < 0.5);
        let again = train(&ex, 10.0, opts, vec![], "t").unwrap();
        assert_eq!(
            serde_json::to_string(&m).unwrap(),
            serde_json::to_string(&again).unwrap()
        );
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("trees.json");
        m.save(&p).unwrap();
        let back = DetectorModel::load(&p).unwrap();
        // JSON keeps 17 significant digits; the last bit may round.
        assert!((back.probability_of(&f) - m.probability_of(&f)).abs() < 1e-12);
        // A split that names a feature that is not there: refused, named.
        let text = std::fs::read_to_string(&p).unwrap();
        let at = text.find("\"feature\": ").unwrap() + "\"feature\": ".len();
        let end = at + text[at..].find(',').unwrap();
        std::fs::write(&p, format!("{}99{}", &text[..at], &text[end..])).unwrap();
        let e = DetectorModel::load(&p).unwrap_err().to_string();
        assert!(
            e.contains("trees.json") && e.contains("trees name a feature"),
            "{e}"
        );
    }

    /// Four folds of 4 sessions a class: each fold holds one session of
    /// each, and a session's windows never straddle two folds.
    #[test]
    fn group_folds_deal_each_classes_sessions_round() {
        let ex = examples();
        let folds = group_folds(&ex, 4, 1);
        for g in 0..8 {
            let of: Vec<usize> = ex
                .iter()
                .zip(&folds)
                .filter(|(e, _)| e.group == format!("s{g}"))
                .map(|(_, &f)| f)
                .collect();
            assert!(of.iter().all(|&f| f == of[0]));
        }
        for k in 0..4 {
            for class in [true, false] {
                let sessions: std::collections::BTreeSet<&str> = ex
                    .iter()
                    .zip(&folds)
                    .filter(|(e, &f)| f == k && e.reading == class)
                    .map(|(e, _)| e.group.as_str())
                    .collect();
                assert_eq!(sessions.len(), 1, "fold {k}, reading {class}");
            }
        }
    }

    #[test]
    fn the_model_gives_p_reading_whichever_class_is_larger() {
        // Reading a small minority (linfa's "positive" is the larger class).
        let ex: Vec<Example> = examples()
            .into_iter()
            .filter(|e| !e.reading || e.group == "s0")
            .collect();
        let m = train(
            &ex,
            10.0,
            TrainOptions {
                validation_fraction: 0.0,
                ..logistic()
            },
            vec![],
            "t",
        )
        .unwrap();
        assert!(m.weights[0] > 0.5, "{:?}", m.weights);
        let mut f = [0.0; FEATURE_COUNT];
        f[0] = 2.0;
        assert!(m.probability_of(&f) > 0.5);
        f[0] = -2.0;
        assert!(m.probability_of(&f) < 0.5);
    }

    #[test]
    fn one_class_only_is_refused() {
        let ex: Vec<Example> = examples().into_iter().filter(|e| e.reading).collect();
        let e = train(&ex, 10.0, logistic(), vec![], "trajectory").unwrap_err();
        assert!(e.to_string().contains("both classes"), "{e}");
    }

    #[test]
    fn a_saved_model_loads_back_and_a_foreign_file_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let m = train(&examples(), 10.0, logistic(), vec![], "trajectory").unwrap();
        let p = dir.path().join("m.json");
        m.save(&p).unwrap();
        let back = DetectorModel::load(&p).unwrap();
        // JSON keeps 17 significant digits; the last bit may round.
        for (a, b) in back
            .std
            .iter()
            .chain(&back.weights)
            .zip(m.std.iter().chain(&m.weights))
        {
            assert!((a - b).abs() <= 1e-12 * b.abs().max(1.0));
        }
        assert!((back.threshold - m.threshold).abs() < 1e-12);
        std::fs::write(&p, "{\"a\": 1}").unwrap();
        let e = DetectorModel::load(&p).unwrap_err().to_string();
        assert!(
            e.contains("m.json") && e.contains("not a detector model (a JSON file without"),
            "{e}"
        );
        // Another format's JSON, and a file that is not text (a PNG's
        // first bytes): each said to be no model, with why.
        std::fs::write(&p, "{\"format\": \"eyereplay-dataset\"}").unwrap();
        let e = DetectorModel::load(&p).unwrap_err().to_string();
        assert!(e.contains("(format \"eyereplay-dataset\", not"), "{e}");
        std::fs::write(&p, b"\x89PNG\r\n\x1a\n\xff\xfe").unwrap();
        let e = DetectorModel::load(&p).unwrap_err().to_string();
        assert!(e.contains("not a detector model (not text"), "{e}");
    }

    /// A model file edited by hand into values no training writes is
    /// refused by its field, naming the file; the written one loads.
    #[test]
    fn a_model_with_impossible_values_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let m = train(&examples(), 10.0, logistic(), vec![], "trajectory").unwrap();
        let p = dir.path().join("m.json");
        for (field, value, says) in [
            ("window_s", serde_json::json!(0.0), "window_s"),
            ("window_s", serde_json::json!(-10.0), "window_s"),
            ("threshold", serde_json::json!(7.0), "threshold"),
            ("threshold", serde_json::json!(-0.1), "threshold"),
            ("kind", serde_json::json!("svm"), "'svm'"),
            // A window longer than any interview's answer, a field of no
            // number (serde named only its column), and numbers that
            // would pin every probability to 0 or 1.
            (
                "window_s",
                serde_json::json!(1e308),
                "window_s must be 2 to 600 s",
            ),
            (
                "threshold",
                serde_json::Value::Null,
                "threshold must be a number, got null",
            ),
            (
                "intercept",
                serde_json::json!(1e300),
                "its intercept is not a finite",
            ),
            (
                "calibration",
                serde_json::json!({"slope": 1e308, "intercept": 0.0}),
                "calibration's slope",
            ),
            (
                "std",
                serde_json::json!(vec![0.0; crate::FEATURE_COUNT]),
                "spread (std) is not above 0",
            ),
            // Weights but no trees: not what a forest's file holds.
            (
                "kind",
                serde_json::json!("bagged_trees"),
                "a 'bagged_trees' model without its `forest`; train it again",
            ),
        ] {
            let mut v = serde_json::to_value(&m).unwrap();
            v[field] = value;
            std::fs::write(&p, serde_json::to_string(&v).unwrap()).unwrap();
            let e = DetectorModel::load(&p).unwrap_err().to_string();
            assert!(e.contains("m.json") && e.contains(says), "{field}: {e}");
            assert!(!e.contains('\n'));
        }
        m.save(&p).unwrap();
        assert!(DetectorModel::load(&p).is_ok());
        // A forest's leaf that is no share is told as such, not as a
        // missing node.
        let trees = train(
            &examples(),
            10.0,
            TrainOptions::default(),
            vec![],
            "trajectory",
        )
        .unwrap();
        let mut v = serde_json::to_value(&trees).unwrap();
        let text = serde_json::to_string(&v).unwrap();
        assert!(text.contains("reading_share"), "{}", &text[..200]);
        fn first_leaf(v: &mut serde_json::Value) -> Option<&mut serde_json::Value> {
            if v.get("reading_share").is_some() {
                return v.get_mut("reading_share");
            }
            match v {
                serde_json::Value::Object(o) => o.values_mut().find_map(first_leaf),
                serde_json::Value::Array(a) => a.iter_mut().find_map(first_leaf),
                _ => None,
            }
        }
        *first_leaf(&mut v).unwrap() = serde_json::json!(5.0);
        std::fs::write(&p, serde_json::to_string(&v).unwrap()).unwrap();
        let e = DetectorModel::load(&p).unwrap_err().to_string();
        assert!(
            e.contains("a leaf of its trees has a reading share outside 0 to 1"),
            "{e}"
        );
    }
}
