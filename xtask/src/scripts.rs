//! The developer scripts under `scripts/` and `scripts/dev/` as `cargo
//! xtask <name>` tasks: each runs its script from the checkout, its
//! arguments passed on unchanged, and its `--help` shows the script's own
//! header.

use anyhow::{bail, Context, Result};
use std::ffi::OsString;
use std::path::Path;

/// One script task.
pub struct Script {
    /// The task's name: `cargo xtask <name>`.
    pub name: &'static str,
    /// The script, relative to the checkout.
    pub path: &'static str,
    /// One line for `cargo xtask`'s list (under 76 columns).
    pub about: &'static str,
}

/// Every script task, in the order `cargo xtask` lists them. The README's
/// own commands (scripts/setup.sh, run.sh, test.sh) stay scripts, and
/// helpers that other scripts call (tflite_to_onnx.py, edf_fixations.py,
/// mediapipe_ref.py, ks_reference.py) are no tasks of their own.
pub const SCRIPTS: &[Script] = &[
    Script {
        name: "fetch-data",
        path: "scripts/fetch-data.sh",
        about: "Real sample recordings for the tests and the bundled default",
    },
    Script {
        name: "face-assets",
        path: "scripts/face-assets.sh",
        about: "Assets of the full-face render mode (face mesh, photos)",
    },
    Script {
        name: "detector-data",
        path: "scripts/detector-data.sh",
        about: "EyeLink fixation sequences and a webcam clip for the detector tests",
    },
    Script {
        name: "carriers",
        path: "scripts/carriers.sh",
        about: "Talking-head carrier videos of the real-face replay mode",
    },
    Script {
        name: "ffmpeg-static",
        path: "scripts/ffmpeg-static.sh",
        about: "A small static FFmpeg for the Python wheel",
    },
    Script {
        name: "default-detector",
        path: "scripts/default-detector.sh",
        about: "Train the default reading detector on the bundled default and put it in the wheel",
    },
    Script {
        name: "python-wheel",
        path: "scripts/python-wheel.sh",
        about: "Build the Python package into a manylinux wheel (target/wheels/)",
    },
    Script {
        name: "python-test",
        path: "scripts/python-test.sh",
        about: "The Python package's tests: the wheel in a fresh venv, pytest",
    },
    Script {
        name: "bench-extract-memory",
        path: "scripts/bench-extract-memory.sh",
        about: "Peak memory of `eyereplay extract` on a one-hour 1080p video",
    },
    Script {
        name: "slurm-local",
        path: "scripts/slurm-local.sh",
        about: "A throw-away single-node Slurm cluster around one command",
    },
    Script {
        name: "test-cluster",
        path: "scripts/test-cluster.sh",
        about: "The cluster test: sharded generation through a local Slurm",
    },
    Script {
        name: "ab-extract",
        path: "scripts/dev/ab-extract.sh",
        about: "Two builds of `eyereplay extract` on one video, A B A B",
    },
    Script {
        name: "cuda-check",
        path: "scripts/dev/cuda-check.sh",
        about: "Extraction's CUDA path against the CPU (needs an NVIDIA GPU)",
    },
    Script {
        name: "face-seeds",
        path: "scripts/dev/face-seeds.sh",
        about: "The bundled default at several seeds, then a pooled face table",
    },
    Script {
        name: "mediapipe-ref",
        path: "scripts/dev/mediapipe_ref.sh",
        about: "MediaPipe Python's reference CSV of a video (`extract --compare`)",
    },
    Script {
        name: "mediapipe-venv",
        path: "scripts/dev/mediapipe-venv.sh",
        about: "The venv of the MediaPipe Python reference",
    },
    Script {
        name: "ks-reference",
        path: "scripts/dev/ks_reference.sh",
        about: "Regenerate the scipy reference values of the KS test",
    },
    Script {
        name: "head-strip",
        path: "scripts/dev/head_strip.py",
        about: "README strip: source head against rendered head",
    },
    Script {
        name: "replay-strip",
        path: "scripts/dev/replay_strip.py",
        about: "README strip: before/after of a replay dataset",
    },
    Script {
        name: "compare-datasets",
        path: "scripts/dev/compare_datasets.py",
        about: "Two dataset folders compared file by file",
    },
    Script {
        name: "rows-diff",
        path: "scripts/dev/rows_diff.py",
        about: "How far two extraction CSVs of the same video are apart",
    },
    Script {
        name: "pool-noise",
        path: "scripts/dev/pool_noise.py",
        about: "Low end of each class's frame speeds in a dataset's pools",
    },
    Script {
        name: "blink-axes-evidence",
        path: "scripts/dev/blink_axes_evidence.py",
        about: "Per-axis or joint blink filling: evidence from webcam extractions",
    },
    Script {
        name: "wheel-features",
        path: "scripts/dev/wheel_features.py",
        about: "Dependencies the wheel would build with other features",
    },
    Script {
        name: "stop-races",
        path: "scripts/dev/stop_races.py",
        about: "Stops evaluate and generate at random moments, counts what each stop left",
    },
];

/// The script task called `name`.
pub fn find(name: &str) -> Option<&'static Script> {
    SCRIPTS.iter().find(|s| s.name == name)
}

/// The script's own header: a shell script's leading comment, a Python
/// script's docstring. Empty when the file cannot be read.
pub fn header(root: &Path, s: &Script) -> String {
    let Ok(text) = std::fs::read_to_string(root.join(s.path)) else {
        return String::new();
    };
    if s.path.ends_with(".py") {
        let Some(start) = text.find("\"\"\"") else {
            return String::new();
        };
        let body = &text[start + 3..];
        return body[..body.find("\"\"\"").unwrap_or(body.len())]
            .trim_end()
            .to_string();
    }
    text.lines()
        .skip_while(|l| l.starts_with("#!"))
        .take_while(|l| l.starts_with('#'))
        .map(|l| l.strip_prefix("# ").unwrap_or(l.trim_start_matches('#')))
        .collect::<Vec<_>>()
        .join("\n")
}

/// Runs the script at `script` (relative to the checkout at `root`) with
/// `args` (bash or python3 by its extension, so no executable bit is
/// needed) and fails with its exit status.
pub fn run(root: &Path, script: &str, args: &[OsString]) -> Result<()> {
    let path = root.join(script);
    if !path.is_file() {
        bail!("{}: no such script in this checkout", path.display());
    }
    let program = if script.ends_with(".py") {
        "python3"
    } else {
        "bash"
    };
    let status = std::process::Command::new(program)
        .arg(&path)
        .args(args)
        .status()
        .with_context(|| format!("running {program} {}", path.display()))?;
    if !status.success() {
        bail!("{script} failed ({status})");
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_script_exists_and_has_a_header() {
        let root = crate::checkout_root();
        for s in SCRIPTS {
            assert!(root.join(s.path).is_file(), "{}", s.path);
            assert!(!header(&root, s).trim().is_empty(), "{}: no header", s.path);
            assert_eq!(find(s.name).map(|f| f.path), Some(s.path));
        }
    }
}
