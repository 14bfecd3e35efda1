//! Sources the test files share.

use eyereplay_sources::{SourceSpec, TimeUnit, ViewingGeometry};
use std::path::PathBuf;

/// A samples table with the default columns, in milliseconds, on a
/// 1920x1080 screen.
pub fn csv_spec(path: PathBuf) -> SourceSpec {
    SourceSpec::Csv {
        path,
        time_column: None,
        x_column: None,
        y_column: None,
        time_unit: TimeUnit::Ms,
        screen_px: [1920.0, 1080.0],
        geometry: ViewingGeometry::default(),
    }
}
