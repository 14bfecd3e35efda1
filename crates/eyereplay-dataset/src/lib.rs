//! Stage 7 of eyereplay: the dataset on disk. This crate is the one owner of
//! every file a dataset folder holds; every reader and writer in eyereplay
//! goes through it.
//!
//! | file | type | read / write |
//! |---|---|---|
//! | `labels.csv` | [`LabelRow`] | [`read_labels`] / [`write_labels`] |
//! | `metadata.json` | [`Metadata`] ([`DatasetMetadata`] + render section) | [`read_metadata`] / [`write_metadata`] |
//! | `pool/<class>.csv` | [`Segment`] | [`read_pool`] / [`write_pool`] |
//! | `pool/<class>_head.csv` | [`PoseRow`] | [`read_pool_heads`] / [`write_pool_heads`] |
//! | `<class>/<class>_NNNN.csv` | canvas px + optional blink | [`read_session_csv`], [`read_blink_column`] |
//! | `<stem>_truth.csv` | [`TruthRow`] | [`read_truth_csv`] / [`write_truth_csv`] |
//! | `<stem>_identity.json` | [`SessionIdentity`], [`EyeGeometry`] | [`SessionIdentity::read`] / [`SessionIdentity::write`] |
//!
//! Paths come from [`layout`] ([`SessionPaths`] for a session's files), so
//! no other crate spells a file name. `metadata.json` carries
//! [`FORMAT_VERSION`]; [`read_metadata`] refuses a dataset of another
//! version with one line that says which versions are involved.
//!
//! [`write_dataset`] writes what `prepare` computed; the renderer adds each
//! session's video, truth and identity files; [`finalize`](crate) is done by
//! the `eyereplay` library once every session is rendered.

mod error;
mod identity;
mod labels;
pub mod layout;
mod metadata;
mod pool;
mod render_settings;
mod session;
mod table;
mod truth;
mod write;

pub use error::DatasetError;
pub use identity::{EyeGeometry, SessionIdentity, Side};
pub use labels::{read_labels, session_paths_of, write_labels, LabelRow, LABELS_HEADER};
pub use layout::{
    check_output_folder, pool_file, pool_head_file, session_file, session_index, SessionPaths,
};
pub use metadata::{
    metadata_bytes, parse_metadata, read_metadata, write_metadata, ClassMetadata, DatasetMetadata,
    FileDigest, Metadata, RenderMetadata, SessionEntry, ToolInfo, FORMAT_VERSION,
};
pub use pool::{
    frame_sources, read_pool, read_pool_heads, write_pool, write_pool_heads, PoseRow, Segment,
    POOL_HEADER, POOL_HEAD_HEADER,
};
pub use render_settings::{
    render_key_line, BackendSettings, ExtractorMatchSettings, FaceBackendSettings, HeadMotion,
    RenderBackend, RenderSettings, MAX_JOBS, MAX_MATCH_READBACK_EVERY,
};
pub use session::{
    check_session_rows, read_blink_column, read_reading_column, read_session_csv,
    session_calibrations, write_session_csv, write_session_csv_with_blinks,
};
pub use truth::{
    check_truth_numbers, has_renderer_truth, read_head_yaw_csv, read_truth_csv, write_truth_csv,
    EyeTruthRow, TruthRow, TRUTH_HEADER,
};
pub use write::{write_dataset, WriteSummary};
