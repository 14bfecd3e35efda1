//! Domain types shared by every eyereplay stage.
//!
//! Positions carry their unit in their type: [`NormPos`] is an iris position
//! normalized within the eye aperture (the paper's `(n_x, n_y)`), [`ScreenPos`]
//! is a gaze point on an eye tracker's screen in pixels, and [`CanvasPos`] is a
//! cursor position on the simulator canvas in pixels. A [`Trajectory`] is
//! generic over the position type, so a normalized trajectory can never be fed
//! where canvas pixels are expected.

mod cache;
mod calibration;
pub mod cancel;
mod class;
pub mod color;
mod error;
mod fsio;
mod hash;
mod image;
pub mod inflight;
mod landmarks;
mod position;
pub mod profile;
mod progress;
mod session_csv;
mod shard;
mod trajectory;

pub use cache::{cache_dir, ArtifactCache, ArtifactKey};
pub use calibration::Calibration;
pub use class::GazeClass;
pub use error::{first_few, show_number, CoreError};
pub use fsio::{
    atomic_write, atomic_write_with, check_writable, find_upwards, read_json_cache, same_file,
    sha256_file, sha256_hex, stale_temp_files, write_json,
};
pub use hash::{mix64, splitmix64, SPLITMIX_GOLDEN};
pub use image::RgbImage;
pub use landmarks::LandmarkModel;
pub use position::{Canvas, CanvasPos, NormPos, PlanePos, ScreenPos, ScreenSize};
pub use progress::{NoProgress, Progress, Stage};
pub use session_csv::{
    push_fixed3, push_point_row, push_u64, read_session_csv, write_session_csv,
    write_session_csv_columns, write_session_csv_with_blinks, SessionRow,
};
pub use shard::{parse_usize_pair, Shard};
pub use trajectory::{mean_of, path_length, Sample, Trajectory};

/// Version of the eyereplay toolkit, recorded in every metadata file.
pub const TOOL_VERSION: &str = env!("CARGO_PKG_VERSION");
