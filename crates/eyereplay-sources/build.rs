//! Declares `cfg(has_sample_data)` for the tests on real recordings (see
//! the eyereplay-build-support crate).

use eyereplay_build_support::{test_prerequisites, Prereq};

fn main() {
    test_prerequisites(&[(
        "has_sample_data",
        Prereq::Files(&[
            ".cache/data/onestop_fixations.csv",
            ".cache/data/syelink/both_eyes.asc",
            ".cache/data/syelink/left_eye.asc",
            ".cache/data/syelink/left_eye_samples.csv",
            ".cache/data/bids/sub-01/beh/sub-01_task-reading_recording-eye1_physio.tsv.gz",
            ".cache/data/bids/sub-01/beh/sub-01_task-reading_recording-eye1_physio.json",
        ]),
    )]);
}
