//! # eyereplay-protocols
//!
//! The research protocols that measure what eyereplay's data is worth,
//! over the pipeline of the `eyereplay` crate:
//!
//! - [`evaluate_detector`]: does a reading detector trained only on
//!   synthetic video work on real recordings (`eyereplay
//!   evaluate-detector`; [`detector_eval`] runs it, [`detector_report`]
//!   writes what it found);
//! - [`replay_eval`]: the replay mode's proofs on a rendered dataset
//!   (`eyereplay evaluate-replay`);
//! - [`localization_eval`]: when someone reads, segment by segment, on
//!   sessions with known per-frame labels (`eyereplay evaluate-localization`);
//! - [`spliced_eval`]: the same on real recordings spliced into mixed
//!   streams, and on real webcam talkers (`evaluate-localization --spliced`).

pub mod detector_eval;
pub mod detector_report;
pub mod localization_eval;
pub mod replay_eval;
pub mod spliced_eval;

pub use detector_eval::{DetectorEvaluation, Protocol};

/// A detector for the localization protocols, and the path that names it
/// in their errors and results: its file, or a program's built-in model.
#[derive(Clone, Copy)]
pub struct NamedDetector<'a> {
    pub model: &'a eyereplay_detect::DetectorModel,
    pub name: &'a std::path::Path,
}
pub use localization_eval::{evaluate_localization, LocalizationEval};
pub use replay_eval::{evaluate_replay, ReplayEval};
pub use spliced_eval::{evaluate_spliced, SpliceOptions, SplicedEval};

use eyereplay::Result;
use eyereplay_core::Progress;
use std::path::Path;

/// Runs the detector protocol of `protocol_path` into `out`: the generated
/// datasets under `train/` and `real/`, the results in
/// `detector_eval.json` and `index.html`; `classifier`, when given,
/// replaces the protocol's.
pub fn evaluate_detector(
    protocol_path: &Path,
    out: &Path,
    cache: &Path,
    classifier: Option<eyereplay_detect::Classifier>,
    progress: &dyn Progress,
) -> Result<DetectorEvaluation> {
    let eval = detector_eval::run_protocol(protocol_path, out, cache, classifier, progress)?;
    detector_report::write(out, &eval)?;
    Ok(eval)
}
