//! The three MediaPipe networks (converted to ONNX by `scripts/models.sh`)
//! and the ONNX Runtime library, loaded with `ort`'s load-dynamic.
//!
//! Why ONNX Runtime rather than tract: on this 2-core machine a whole frame
//! (detector + mesh + two irises) took about 7 ms with ONNX Runtime and
//! about 20 ms with tract-onnx (shared RESEARCH.md, section 1), and the
//! library comes prebuilt inside the pinned `onnxruntime` wheel, so the build
//! downloads nothing.

use crate::error::{ExtractError, Result};
use ort::execution_providers::{CUDAExecutionProvider, ExecutionProvider};
use ort::session::builder::{GraphOptimizationLevel, SessionBuilder};
use ort::session::Session;
use ort::value::TensorRef;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

pub const DETECTOR: &str = "face_detection_short_range.onnx";
pub const MESH: &str = "face_landmark.onnx";
pub const IRIS: &str = "iris_landmark.onnx";
pub const ORT_LIB: &str = "libonnxruntime.so.1.22.1";

/// The pinned sha256 of the `.tflite` files the ONNX files are made from
/// (as shipped in the mediapipe==0.10.21 wheel).
pub const TFLITE_SHA256: [(&str, &str); 3] = [
    (
        "face_detection_short_range.tflite",
        "bbff11cebd1eb27a1e004cae0b0e63ec8c551cbf34a4451148b4908b8db3eca8",
    ),
    (
        "face_landmark.tflite",
        "1055cb9d4a9ca8b8c688902a3a5194311138ba256bcc94e336d8373a5f30c814",
    ),
    (
        "iris_landmark.tflite",
        "d1744d2a09c25f501d39eba4faff47e53ecca8852c5ce19bce8eeac39357521f",
    ),
];

/// Where the models live: `$EYEREPLAY_MODELS`, else `.cache/models` in the
/// current directory or the nearest ancestor that has one (so the binary
/// works from anywhere inside the checkout).
pub fn default_models_dir() -> PathBuf {
    if let Some(d) = std::env::var_os("EYEREPLAY_MODELS") {
        return PathBuf::from(d);
    }
    if let Some(marker) = eyereplay_core::find_upwards(&Path::new(".cache/models").join(DETECTOR)) {
        return marker.parent().expect("a file has a folder").to_path_buf();
    }
    PathBuf::from(".cache/models")
}

/// The ONNX Runtime library: `$EYEREPLAY_ORT_LIB` when set (for example
/// the `libonnxruntime.so` of an `onnxruntime-gpu` install, which has the
/// CUDA execution provider), else the pinned CPU build in the models folder.
pub fn runtime_library(dir: &Path) -> PathBuf {
    match std::env::var_os("EYEREPLAY_ORT_LIB") {
        Some(p) => PathBuf::from(p),
        None => dir.join(ORT_LIB),
    }
}

/// Names of the files missing from `dir` (empty when all are there).
pub fn missing_files(dir: &Path) -> Vec<&'static str> {
    let mut missing: Vec<&'static str> = [DETECTOR, MESH, IRIS]
        .into_iter()
        .filter(|f| !dir.join(f).is_file())
        .collect();
    if !runtime_library(dir).is_file() {
        missing.push(ORT_LIB);
    }
    missing
}

/// Verifies the models folder: all files present and the `.tflite` sources
/// matching their pinned sha256. Returns one line per checked file.
pub fn check(dir: &Path) -> Result<Vec<String>> {
    let missing = missing_files(dir);
    if !missing.is_empty() {
        return Err(ExtractError::ModelsMissing {
            dir: dir.to_path_buf(),
            missing: missing.join(", "),
        });
    }
    let mut lines = vec![];
    for (file, want) in TFLITE_SHA256 {
        let p = dir.join(file);
        let got = eyereplay_core::sha256_file(&p)?;
        if got != want {
            return Err(ExtractError::ModelChecksum {
                path: p,
                expected: want.into(),
                actual: got,
            });
        }
        lines.push(format!("{file}: sha256 {got} (pinned, ok)"));
    }
    init_runtime(dir)?;
    let mut m = Models::load(dir)?;
    // One inference each on a grey image proves the graphs run and have the
    // expected output sizes.
    let grey = vec![0.5f32; 3 * 192 * 192];
    let (reg, scores) = m.detect(&grey[..3 * 128 * 128])?;
    lines.push(format!(
        "{DETECTOR}: runs, {} anchors x {} values",
        scores.len(),
        reg.len() / scores.len().max(1)
    ));
    let (lm, _) = m.mesh(&grey)?;
    lines.push(format!("{MESH}: runs, {} landmarks", lm.len() / 3));
    let eyes = vec![0.5f32; 2 * 3 * 64 * 64];
    let out = m.iris(&eyes)?;
    lines.push(format!(
        "{IRIS}: runs, 2 eyes x ({} contour + {} iris points)",
        out[0].0.len() / 3,
        out[0].1.len() / 3
    ));
    let cuda = CUDAExecutionProvider::default()
        .is_available()
        .unwrap_or(false);
    lines.push(format!(
        "{}: loaded ({})",
        runtime_library(dir).display(),
        if cuda {
            "CUDA execution provider available"
        } else {
            "CPU only"
        }
    ));
    Ok(lines)
}

static RUNTIME: OnceLock<std::result::Result<(), String>> = OnceLock::new();

/// Loads `libonnxruntime.so` from the models folder (once per process).
pub fn init_runtime(dir: &Path) -> Result<()> {
    let lib = runtime_library(dir);
    RUNTIME
        .get_or_init(|| {
            if !lib.is_file() {
                return Err(format!(
                    "{} not found; run `eyereplay models fetch`",
                    lib.display()
                ));
            }
            ort::init_from(lib.to_string_lossy().to_string())
                .with_name("eyereplay")
                .commit()
                .map(|_| ())
                .map_err(|e| e.to_string())
        })
        .clone()
        .map_err(ExtractError::Runtime)
}

/// Where the networks run.
///
/// The CPU is the default even where a GPU is present: these networks are
/// so small (about 0.1-0.25 GFLOP an inference) that the CUDA execution
/// provider's per-inference launch, copy and synchronisation cost exceeds
/// the CPU's whole inference. Measured on an NVIDIA H200 with onnxruntime-gpu
/// 1.31.1 (README, "Where extraction's CPU time goes"): 2.2-2.5x the wall time
/// and 1.8-2x the CPU time per frame of the CPU path with 2 workers.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Device {
    /// CUDA when the loaded ONNX Runtime library has its CUDA execution
    /// provider and it starts, else the CPU (silently: the pinned library
    /// is a CPU build).
    Auto,
    /// Always the CPU.
    #[default]
    Cpu,
    /// CUDA; falls back to the CPU with a one-line warning when the
    /// library lacks the provider or it fails to start.
    Cuda,
}

/// One set of sessions; each worker thread owns one.
pub struct Models {
    detector: Session,
    mesh: Session,
    iris: Session,
    /// True when the sessions run on CUDA.
    pub on_cuda: bool,
}

fn cpu_builder() -> Result<SessionBuilder> {
    // One thread per inference and no spinning: on 2 cores two threads per
    // inference measured slower than one, and the parallelism comes from
    // running one worker per core instead.
    Ok(Session::builder()?
        .with_optimization_level(GraphOptimizationLevel::Level3)?
        .with_intra_threads(1)?
        .with_inter_threads(1)?
        .with_config_entry("session.intra_op.allow_spinning", "0")?
        .with_config_entry("session.inter_op.allow_spinning", "0")?)
}

/// Warns once per process that CUDA was asked for but is not used.
fn cpu_fallback_notice(why: &str) {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| tracing::warn!("CUDA not used ({why}); running the networks on the CPU"));
}

/// A session on CUDA when `cuda` (ONNX Runtime puts operators CUDA lacks on
/// the CPU), else, or when CUDA fails to start, on the CPU; the flag says
/// which.
fn session(path: &Path, cuda: bool) -> Result<(Session, bool)> {
    if cuda {
        // TF32 off: ONNX Runtime turns it on by default, and with it the
        // rows moved up to 2e-3 in nx from the CPU's (H200, median 7e-5);
        // the speed it buys is irrelevant for networks this small.
        let ep = CUDAExecutionProvider::default()
            .with_tf32(false)
            .build()
            .error_on_failure();
        match cpu_builder()?.with_execution_providers([ep]) {
            Ok(b) => match b.commit_from_file(path) {
                Ok(s) => return Ok((s, true)),
                Err(e) => cpu_fallback_notice(&format!("{}: {e}", path.display())),
            },
            Err(e) => cpu_fallback_notice(&e.to_string()),
        }
    }
    Ok((cpu_builder()?.commit_from_file(path)?, false))
}

/// Whether to try CUDA for `device` with the library already loaded.
fn want_cuda(device: Device, dir: &Path) -> bool {
    match device {
        Device::Cpu => false,
        Device::Auto | Device::Cuda => {
            let have = CUDAExecutionProvider::default()
                .is_available()
                .unwrap_or(false);
            if !have && device == Device::Cuda {
                cpu_fallback_notice(&format!(
                    "{} has no CUDA execution provider; point EYEREPLAY_ORT_LIB at an \
                     onnxruntime-gpu build",
                    runtime_library(dir).display()
                ));
            }
            have
        }
    }
}

/// Iris model output for one eye: 71 contour points and 5 iris points, each
/// (x, y, z) in the 64x64 crop's pixels.
pub type IrisOut = (Vec<f32>, Vec<f32>);

impl Models {
    /// [`Models::load_on`] with the default [`Device`] (the CPU).
    pub fn load(dir: &Path) -> Result<Models> {
        Models::load_on(dir, Device::default())
    }

    pub fn load_on(dir: &Path, device: Device) -> Result<Models> {
        let missing = missing_files(dir);
        if !missing.is_empty() {
            return Err(ExtractError::ModelsMissing {
                dir: dir.to_path_buf(),
                missing: missing.join(", "),
            });
        }
        init_runtime(dir)?;
        let cuda = want_cuda(device, dir);
        let (detector, a) = session(&dir.join(DETECTOR), cuda)?;
        let (mesh, b) = session(&dir.join(MESH), cuda)?;
        let (iris, c) = session(&dir.join(IRIS), cuda)?;
        Ok(Models {
            detector,
            mesh,
            iris,
            on_cuda: a && b && c,
        })
    }

    /// Face detector on a 1x3x128x128 input in [-1, 1]: (regressors 896x16,
    /// score logits 896).
    pub fn detect(&mut self, input: &[f32]) -> Result<(Vec<f32>, Vec<f32>)> {
        let t = TensorRef::from_array_view(([1usize, 3, 128, 128], input))?;
        let out = self.detector.run(ort::inputs!["input" => t])?;
        let (_, reg) = out["regressors"].try_extract_tensor::<f32>()?;
        let (_, sc) = out["classificators"].try_extract_tensor::<f32>()?;
        Ok((reg.to_vec(), sc.to_vec()))
    }

    /// Face mesh on a 1x3x192x192 input in [0, 1]: (468 x (x,y,z) in crop
    /// pixels, face presence logit).
    pub fn mesh(&mut self, input: &[f32]) -> Result<(Vec<f32>, f32)> {
        let t = TensorRef::from_array_view(([1usize, 3, 192, 192], input))?;
        let out = self.mesh.run(ort::inputs!["input" => t])?;
        let (_, lm) = out["conv2d_21_flat"].try_extract_tensor::<f32>()?;
        let (_, sc) = out["conv2d_31_flat"].try_extract_tensor::<f32>()?;
        Ok((lm.to_vec(), sc[0]))
    }

    /// Iris model on one eye (a 1x3x64x64 input in [0, 1]). The pipeline
    /// batches both eyes ([`Models::iris`]); this is the unbatched
    /// reference the batch must equal.
    pub fn iris_single(&mut self, input: &[f32]) -> Result<IrisOut> {
        let t = TensorRef::from_array_view(([1usize, 3, 64, 64], input))?;
        let out = self.iris.run(ort::inputs!["input" => t])?;
        let (_, contour) = out["output_eyes_contours_and_brows"].try_extract_tensor::<f32>()?;
        let (_, iris) = out["output_iris"].try_extract_tensor::<f32>()?;
        Ok((contour.to_vec(), iris.to_vec()))
    }

    /// Iris model on both eyes at once (a 2x3x64x64 batch in [0, 1]): one
    /// inference instead of two halves the per-run overhead of ONNX Runtime.
    pub fn iris(&mut self, input: &[f32]) -> Result<[IrisOut; 2]> {
        let mut out = self.iris_batch(&input[..2 * 3 * 64 * 64], 2)?;
        let second = out.pop().expect("two eyes");
        let first = out.pop().expect("two eyes");
        Ok([first, second])
    }

    /// Iris model on `eyes` crops at once (an `eyes`x3x64x64 batch in [0, 1],
    /// `input` exactly that long): one output per crop, in order.
    pub fn iris_batch(&mut self, input: &[f32], eyes: usize) -> Result<Vec<IrisOut>> {
        let t = TensorRef::from_array_view(([eyes, 3, 64, 64], input))?;
        let out = self.iris.run(ort::inputs!["input" => t])?;
        let (_, contour) = out["output_eyes_contours_and_brows"].try_extract_tensor::<f32>()?;
        let (_, iris) = out["output_iris"].try_extract_tensor::<f32>()?;
        Ok(contour
            .chunks_exact(213)
            .zip(iris.chunks_exact(15))
            .map(|(c, i)| (c.to_vec(), i.to_vec()))
            .collect())
    }
}
