//! Evaluation of an eyereplay dataset (issue 5, paper section 5):
//! eye-movement metrics, a two-sample KS test that agrees with scipy,
//! distributional fidelity of generated sessions against their source pool,
//! visual mapping fidelity of a render against its source, plots (PNG and
//! SVG) and a self-contained HTML report with a deterministic metrics.json.

pub mod behaviour;
pub mod dataset;
pub mod distribution;
mod error;
mod evaluation;
pub mod json;
pub mod ks;
pub mod metrics;
mod metrics_doc;
pub mod stats;
pub mod visual;

pub use behaviour::{behaviour_table, check_behaviour, BehaviourCheck, BehaviourRow};
pub use dataset::{load_dataset, Dataset};
pub use distribution::{compare_metric, evaluate_class, ClassEvaluation, EvalConfig, Metric};
pub use error::EvalError;
pub use ks::{ks_2samp, KsMethod, KsResult};
pub use metrics::{
    detect_events, speeds_px_per_frame, Event, EventKind, IvtThresholds, MetricSamples,
};
pub use visual::{
    compare_visual, read_back_budget, AxisBudget, EyeReadBack, ReadBackBudget, VisualFidelity,
};
pub mod plot;
pub mod report;
pub use evaluation::{
    evaluate_dataset, Evaluation, HeadYawReadBack, SessionReadBack, VisualRun, VisualSection,
    HEAD_YAW_READ_BACK_S, TARGET_HEAD_YAW_R_MIN,
};
pub use eyereplay_core::Calibration;
pub use metrics_doc::metrics_json;
pub use report::{check_report_place, html_escape, write_report};
