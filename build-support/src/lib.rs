//! Shared by the build scripts of crates whose tests need the real sample
//! data (.cache/data), the models (.cache/models) or the ffmpeg command: a
//! build-dependency, so every crate packages on its own.
//!
//! For each prerequisite that is there, sets `cfg(<name>)`; tests that need
//! it carry `#[cfg_attr(not(<name>), ignore = "needs ...: run
//! scripts/setup.sh")]`, so a plain `cargo test` without them lists those
//! tests as ignored, with the reason, instead of passing them silently.
//! With `CI` set (non-empty, not "false" or "0") a missing prerequisite
//! fails the build in one line.

/// One thing tests need.
pub enum Prereq {
    /// Files under the repository root.
    Files(&'static [&'static str]),
    /// The model files, in `$EYEREPLAY_MODELS` or `.cache/models`.
    Models,
    /// A command that answers `-version`.
    Command(&'static str),
}

/// The files `eyereplay_extract::missing_files` checks.
const MODEL_FILES: &[&str] = &[
    "face_detection_short_range.onnx",
    "face_landmark.onnx",
    "iris_landmark.onnx",
    "libonnxruntime.so.1.22.1",
];

/// Declares every cfg in `prereqs` (name, what it needs), sets those whose
/// prerequisites are present, and fails the build under CI when one is not.
pub fn test_prerequisites(prereqs: &[(&str, Prereq)]) {
    use std::path::PathBuf;
    let manifest = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").expect("cargo sets it"));
    let root = manifest.join("../..");
    println!("cargo:rerun-if-env-changed=CI");
    let ci = std::env::var("CI").is_ok_and(|v| !v.is_empty() && v != "false" && v != "0");
    let mut missing: Vec<String> = Vec::new();
    for (cfg, prereq) in prereqs {
        println!("cargo::rustc-check-cfg=cfg({cfg})");
        let absent: Vec<String> = match prereq {
            Prereq::Files(files) => files
                .iter()
                .filter(|f| {
                    let p = root.join(f);
                    // A missing path reruns this script on every build, so
                    // the cfg turns on as soon as setup.sh has fetched it.
                    println!("cargo:rerun-if-changed={}", p.display());
                    !p.exists()
                })
                .map(|f| f.to_string())
                .collect(),
            Prereq::Models => {
                println!("cargo:rerun-if-env-changed=EYEREPLAY_MODELS");
                let dir = std::env::var_os("EYEREPLAY_MODELS")
                    .map(PathBuf::from)
                    .unwrap_or_else(|| root.join(".cache/models"));
                MODEL_FILES
                    .iter()
                    .filter(|f| {
                        let p = dir.join(f);
                        println!("cargo:rerun-if-changed={}", p.display());
                        !p.is_file()
                    })
                    .map(|f| format!(".cache/models/{f}"))
                    .collect()
            }
            Prereq::Command(cmd) => {
                println!("cargo:rerun-if-env-changed=PATH");
                let ok = std::process::Command::new(cmd)
                    .arg("-version")
                    .output()
                    .is_ok_and(|o| o.status.success());
                if ok {
                    vec![]
                } else {
                    vec![format!("the {cmd} command")]
                }
            }
        };
        if absent.is_empty() {
            println!("cargo:rustc-cfg={cfg}");
        } else {
            for a in absent {
                if !missing.contains(&a) {
                    missing.push(a);
                }
            }
        }
    }
    if ci && !missing.is_empty() {
        eprintln!(
            "{} tests need {}: run scripts/setup.sh (CI is set, so this fails the build instead of ignoring those tests)",
            std::env::var("CARGO_PKG_NAME").unwrap_or_default(),
            missing.join(", ")
        );
        std::process::exit(1);
    }
}
