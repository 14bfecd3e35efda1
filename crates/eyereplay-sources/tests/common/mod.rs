//! Sources the test files share.

use eyereplay_sources::{EyeChoice, SourceSpec, TimeUnit, ViewingGeometry};
use std::path::PathBuf;

/// A samples table with the default columns, in milliseconds, on a
/// 1920x1080 screen.
#[allow(dead_code)] // not every test file reads samples tables
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

/// An EyeLink ASCII file, `eye` read, its screen from the file.
#[allow(dead_code)] // not every test file reads EyeLink files
pub fn eyelink_spec(path: PathBuf, eye: EyeChoice) -> SourceSpec {
    SourceSpec::Eyelink {
        path,
        eye,
        screen_px: None,
        geometry: ViewingGeometry::default(),
    }
}
