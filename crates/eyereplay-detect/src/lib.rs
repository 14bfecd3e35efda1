//! # eyereplay-detect
//!
//! The reading detector: does a window of gaze show someone reading?
//!
//! | step | here |
//! |---|---|
//! | a 25 fps gaze series, cut into windows, each normalized and oriented | [`window`] |
//! | 14 documented features per window | [`features()`] |
//! | bagged decision trees over them (the default) | [`forest`] |
//! | or a logistic regression; calibration and threshold on held-out sessions | [`model`] |
//! | the zero-training rule (forward-saccade runs) | [`features::rule_score`] |
//! | AUROC, ROC curve, bootstrap over people | [`metrics`] |
//! | per-frame probability, reading segments, segment F1 | [`localize`] |
//! | clips shorter than a window, with a bootstrap interval | [`clip`] |
//! | reliability, expected calibration error, threshold for a false-positive rate | [`calibration`] |
//!
//! The detector sees what `eyereplay extract` measures on a video, the same
//! input in training (on rendered video) and in use (on a real one); the
//! umbrella crate `eyereplay` wires it to datasets and videos.

pub mod calibration;
pub mod clip;
#[cfg(feature = "cnn")]
pub mod cnn;
mod error;
pub mod features;
pub mod forest;
pub mod localize;
pub mod metrics;
pub mod model;
mod moments;
pub mod window;

pub use error::DetectError;
pub use features::{features, rule_score, FEATURE_COUNT, FEATURE_NAMES};
pub use metrics::{auroc, pairwise_auroc, roc_curve, AurocCi, PairAuroc};
pub use model::{
    train, Classifier, DetectorModel, Example, TrainOptions, MAX_WINDOW_S, MIN_WINDOW_S,
};
pub use window::{windows, Track, Window, WindowSpec, FPS};
