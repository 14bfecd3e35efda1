//! MediaPipe's networks (converted to ONNX by `scripts/models.sh`: the face
//! detector, the face mesh and iris model of the cascade, the attention face
//! mesh) and the ONNX Runtime library, loaded with `ort`'s load-dynamic.
//!
//! Why ONNX Runtime rather than tract: on this 2-core machine a whole frame
//! (detector + mesh + two irises) took about 7 ms with ONNX Runtime and
//! about 20 ms with tract-onnx (shared RESEARCH.md, section 1), and the
//! library comes prebuilt inside the pinned `onnxruntime` wheel, so the build
//! downloads nothing.

use crate::attention::EyeCropSpec;
use crate::error::{ExtractError, Result};
use crate::shapes::{
    DETECTOR_ANCHORS, DETECTOR_ANCHOR_VALUES, EYE_CONTOUR_POINTS, FACE_MESH_LANDMARKS, IRIS_POINTS,
};
use ort::execution_providers::{CUDAExecutionProvider, ExecutionProvider};
use ort::session::builder::{GraphOptimizationLevel, SessionBuilder};
use ort::session::Session;
use ort::value::TensorRef;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

pub const DETECTOR: &str = "face_detection_short_range.onnx";
pub const MESH: &str = "face_landmark.onnx";
pub const IRIS: &str = "iris_landmark.onnx";
/// Crops the iris model reads per run on the CPU ([`Models::iris_batch`]):
/// one frame's two eyes. Five views per eye read as five runs of two took
/// 14 % less of the iris network's CPU time than one run of ten, and one
/// crop a run more (ONNX Runtime 1.22 on 2-core x86; docs/EXTRACTION.md).
pub const IRIS_CPU_BATCH: usize = 2;
/// MediaPipe's attention face mesh (`refine_landmarks=True` in its Python
/// face mesh), split by `scripts/tflite_to_onnx.py --split-eyes`: the face
/// model (mesh, face flag, the feature map the eyes are read from) ...
pub const ATTENTION: &str = "face_landmark_with_attention.onnx";
/// ... and the eye model (eye contours and irises from each eye's crop of
/// that map); the custom operators between them are [`crate::attention`].
pub const ATTENTION_EYES: &str = "face_landmark_with_attention_eyes.onnx";
pub const ORT_LIB: &str = "libonnxruntime.so.1.22.1";
/// The pinned sha256 of [`ORT_LIB`] as shipped in the onnxruntime==1.22.1
/// wheel (`scripts/models.sh` checks it when it unpacks the library).
pub const ORT_LIB_SHA256: &str = "ad9665887025474170d3e71cd28021e7e811c5bf201bc365f953e34a2c4989cc";
/// The networks `scripts/models.sh` converts, each checked against the
/// sha256 the conversion recorded (see [`conversion_records`]).
pub const NETWORKS: [&str; 5] = [DETECTOR, MESH, IRIS, ATTENTION, ATTENTION_EYES];

/// The pinned sha256 of the `.tflite` files the ONNX files are made from
/// (as shipped in the mediapipe==0.10.21 wheel).
pub const TFLITE_SHA256: [(&str, &str); 4] = [
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
    (
        "face_landmark_with_attention.tflite",
        "e06a804e0144f9929eda782122916b35d60c697c3c9344013ca2bbe76a6ce2b4",
    ),
];

/// Model and runtime locations an installed package supplies
/// ([`use_package_files`]): used when no environment variable names them.
static PACKAGE_FILES: std::sync::RwLock<Option<(PathBuf, Option<PathBuf>)>> =
    std::sync::RwLock::new(None);

/// Makes `models_dir` (and, when given, `runtime_library` as the ONNX
/// Runtime library) this process's defaults: how an installed package
/// (the Python wheel, which ships the models and the library inside it)
/// works from any folder. `$EYEREPLAY_MODELS` and `$EYEREPLAY_ORT_LIB`
/// still win.
pub fn use_package_files(models_dir: PathBuf, runtime_library: Option<PathBuf>) {
    let mut g = PACKAGE_FILES.write().unwrap_or_else(|p| p.into_inner());
    *g = Some((models_dir, runtime_library));
}

fn package_files() -> Option<(PathBuf, Option<PathBuf>)> {
    PACKAGE_FILES
        .read()
        .unwrap_or_else(|p| p.into_inner())
        .clone()
}

/// Where the models live: `$EYEREPLAY_MODELS`; else the installed
/// package's own ([`use_package_files`]); else `$EYEREPLAY_CACHE/models`
/// when it holds them (where `scripts/models.sh` puts them with that
/// variable set); else `.cache/models` in the current directory or the
/// nearest ancestor that has one (so the binary works from anywhere
/// inside the checkout); found nowhere, `$EYEREPLAY_CACHE/models` when
/// that is set (the error then names the folder the user gave), else
/// `.cache/models`.
pub fn default_models_dir() -> PathBuf {
    if let Some(d) = std::env::var_os("EYEREPLAY_MODELS") {
        return PathBuf::from(d);
    }
    if let Some((dir, _)) = package_files() {
        return dir;
    }
    let in_cache = std::env::var_os("EYEREPLAY_CACHE")
        .filter(|c| !c.is_empty())
        .map(|c| PathBuf::from(c).join("models"));
    if let Some(dir) = in_cache.as_ref().filter(|d| d.join(DETECTOR).is_file()) {
        return dir.clone();
    }
    if let Some(marker) = eyereplay_core::find_upwards(&Path::new(".cache/models").join(DETECTOR)) {
        return marker.parent().expect("a file has a folder").to_path_buf();
    }
    // Found nowhere: the error names the folder the user set, if any.
    in_cache.unwrap_or_else(|| PathBuf::from(".cache/models"))
}

/// The ONNX Runtime library: `$EYEREPLAY_ORT_LIB` when set (for example
/// the `libonnxruntime.so` of an `onnxruntime-gpu` install, which has the
/// CUDA execution provider); else the installed package's own
/// ([`use_package_files`]); else the pinned CPU build in the models folder.
pub fn runtime_library(dir: &Path) -> PathBuf {
    if let Some(p) = std::env::var_os("EYEREPLAY_ORT_LIB") {
        return PathBuf::from(p);
    }
    match package_files() {
        Some((_, Some(lib))) => lib,
        _ => dir.join(ORT_LIB),
    }
}

/// A short digest of what an extraction's rows depend on outside the
/// code: the sha256 of every network file in `dir` (or that it is
/// absent) and the ONNX Runtime library's file name and size. Cached
/// extractions, head poses and carrier tracks carry it in their keys, so
/// rows made with other networks (`$EYEREPLAY_MODELS` pointed elsewhere, a
/// new conversion, a GPU build of the runtime) are never taken for these.
/// Hashed once per folder per process (about 10 MB).
pub fn networks_fingerprint(dir: &Path) -> Result<String> {
    static SEEN: std::sync::Mutex<Vec<(PathBuf, String)>> = std::sync::Mutex::new(Vec::new());
    let mut seen = SEEN.lock().unwrap_or_else(|p| p.into_inner());
    if let Some((_, f)) = seen.iter().find(|(d, _)| d == dir) {
        return Ok(f.clone());
    }
    let mut record = String::new();
    for name in NETWORKS {
        let path = dir.join(name);
        let digest = if path.is_file() {
            eyereplay_core::sha256_file(&path)?
        } else {
            "absent".to_string()
        };
        record.push_str(&format!("{name} {digest}\n"));
    }
    let lib = runtime_library(dir);
    let lib_bytes = std::fs::metadata(&lib).map(|m| m.len()).unwrap_or(0);
    let lib_name = lib.file_name().unwrap_or_default().to_string_lossy();
    record.push_str(&format!("{lib_name} {lib_bytes}\n"));
    let fingerprint = eyereplay_core::sha256_hex(record.as_bytes())[..12].to_string();
    seen.push((dir.to_path_buf(), fingerprint.clone()));
    Ok(fingerprint)
}

/// Names of the files missing from `dir` (empty when all are there).
pub fn missing_files(dir: &Path) -> Vec<&'static str> {
    let mut missing: Vec<&'static str> = [DETECTOR, MESH, IRIS, ATTENTION, ATTENTION_EYES]
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
    check_with(dir, false)
}

/// [`check`] for `eyereplay models check`, which is asked to verify: a
/// network whose conversion recorded no sha256 cannot be, and fails it.
/// (The check before every job only says so: a folder converted by an
/// older `scripts/models.sh`, or by hand, still runs.)
pub fn check_strict(dir: &Path) -> Result<Vec<String>> {
    check_with(dir, true)
}

fn check_with(dir: &Path, strict: bool) -> Result<Vec<String>> {
    if dir.is_file() {
        return Err(ExtractError::Io {
            path: dir.to_path_buf(),
            source: std::io::Error::new(
                std::io::ErrorKind::NotADirectory,
                "a file, not a models folder",
            ),
        });
    }
    let missing = missing_files(dir);
    if !missing.is_empty() {
        return Err(ExtractError::ModelsMissing {
            dir: dir.to_path_buf(),
            missing: missing.join(", "),
        });
    }
    let mut lines = vec![];
    const PINNED: &str = "the pinned sha256";
    for (file, want) in TFLITE_SHA256 {
        let p = dir.join(file);
        if !p.is_file() {
            // An installed package ships the converted networks only.
            lines.push(format!("{file}: source not here (converted networks only)"));
            continue;
        }
        let got = verify_sha256(&p, want, PINNED)?;
        lines.push(format!("{file}: sha256 {got} (pinned, ok)"));
    }
    // The ONNX files are made on the user's machine, so no hash is pinned
    // for them; the conversion records each output's, and a file changed
    // since (a byte flipped that still runs) is caught here.
    let records = conversion_records(dir)?;
    for file in NETWORKS {
        let Some(want) = records.get(file) else {
            if strict {
                return Err(ExtractError::ModelUnverified {
                    path: dir.join(file),
                });
            }
            let line = format!(
                "{file}: no sha256 recorded at its conversion, so it is not checked (made by hand \
                 or by an older scripts/models.sh; run scripts/setup.sh to convert and record it)"
            );
            // Every job runs it, and says so once a process.
            static TOLD: std::sync::Mutex<Vec<PathBuf>> = std::sync::Mutex::new(Vec::new());
            let path = dir.join(file);
            let mut told = TOLD.lock().unwrap_or_else(|p| p.into_inner());
            if !told.contains(&path) {
                tracing::warn!("{}: {line}", dir.display());
                told.push(path);
            }
            lines.push(line);
            continue;
        };
        let got = verify_sha256(
            &dir.join(file),
            want,
            "the sha256 recorded at its conversion",
        )?;
        lines.push(format!("{file}: sha256 {got} (as converted, ok)"));
    }
    // The pinned library, wherever it was found (the models folder or an
    // installed package); one named by $EYEREPLAY_ORT_LIB is the user's.
    let lib = runtime_library(dir);
    if std::env::var_os("EYEREPLAY_ORT_LIB").is_none()
        && lib.file_name() == Some(std::ffi::OsStr::new(ORT_LIB))
    {
        let got = verify_sha256(&lib, ORT_LIB_SHA256, PINNED)?;
        lines.push(format!("{ORT_LIB}: sha256 {got} (pinned, ok)"));
    }
    init_runtime(dir)?;
    let mut m = Models::load(dir)?;
    // One inference each on a grey image proves the graphs run and have the
    // expected output sizes.
    let grey = vec![0.5f32; 3 * 192 * 192];
    let det = m.detect(&grey[..3 * 128 * 128])?;
    lines.push(format!(
        "{DETECTOR}: runs, {} anchors x {} values",
        det.scores.len(),
        det.regressors.len() / det.scores.len().max(1)
    ));
    let mesh = m.mesh(&grey)?;
    lines.push(format!(
        "{MESH}: runs, {} landmarks",
        mesh.landmarks.len() / 3
    ));
    let eyes = vec![0.5f32; 2 * 3 * 64 * 64];
    let out = m.iris(&eyes)?;
    lines.push(format!(
        "{IRIS}: runs, 2 eyes x ({} contour + {} iris points)",
        out[0].contour.len() / 3,
        out[0].iris.len() / 3
    ));
    let att = m.attention(&grey)?;
    lines.push(format!(
        "{ATTENTION}: runs, {} landmarks + 2 eyes x ({} contour + {} iris points)",
        att.mesh.len() / 3,
        att.eyes[0].len() / 2,
        att.irises[0].len() / 2
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

/// `path`'s sha256 when it is `want`, else a [`ExtractError::ModelChecksum`]
/// saying whose hash `want` is (`against`).
fn verify_sha256(path: &Path, want: &str, against: &'static str) -> Result<String> {
    let got = eyereplay_core::sha256_file(path)?;
    if got != want {
        return Err(ExtractError::ModelChecksum {
            path: path.to_path_buf(),
            against,
            expected: want.into(),
            actual: got,
        });
    }
    Ok(got)
}

/// The sha256 of each converted network as `scripts/models.sh` recorded
/// it: the `.onnx.src` stamps in `dir`, whose first line names the source
/// and converter and whose further lines read `sha256 HEX FILE`, one per
/// file the conversion wrote. Keyed by file name.
pub fn conversion_records(dir: &Path) -> Result<std::collections::BTreeMap<String, String>> {
    let mut records = std::collections::BTreeMap::new();
    for file in NETWORKS {
        let stamp = dir.join(format!("{file}.src"));
        let Ok(text) = std::fs::read_to_string(&stamp) else {
            continue; // no stamp: the file is another conversion's output
        };
        for (i, line) in text.lines().enumerate().skip(1) {
            let bad = || {
                ExtractError::Runtime(format!(
                    "{}: line {}: expected 'sha256 HEX FILE', found '{line}'; \
                     run scripts/setup.sh to convert the models again",
                    stamp.display(),
                    i + 1
                ))
            };
            let mut words = line.split_whitespace();
            let (Some("sha256"), Some(hex), Some(name), None) =
                (words.next(), words.next(), words.next(), words.next())
            else {
                return Err(bad());
            };
            if hex.len() != 64 || !hex.bytes().all(|b| b.is_ascii_hexdigit()) {
                return Err(bad());
            }
            records.insert(name.to_string(), hex.to_ascii_lowercase());
        }
    }
    Ok(records)
}

/// The outcome of loading the runtime library: `Ok`, or an
/// [`ExtractError::Runtime`].
static RUNTIME: OnceLock<Result<()>> = OnceLock::new();

/// Loads `libonnxruntime.so` from the models folder (once per process).
pub fn init_runtime(dir: &Path) -> Result<()> {
    let lib = runtime_library(dir);
    let r = RUNTIME.get_or_init(|| {
        if !lib.is_file() {
            return Err(ExtractError::Runtime(format!(
                "{} not found; run scripts/setup.sh (or `cargo xtask models`)",
                lib.display()
            )));
        }
        // ort panics (with a backtrace) when the file does not load or
        // lacks ONNX Runtime's entry point; try both here first.
        // SAFETY: loading runs the library's initializers, as ort's own
        // load right after does; the handle only checks one symbol.
        unsafe {
            let handle = libloading::Library::new(&lib).map_err(|e| {
                ExtractError::Runtime(format!(
                    "{}: not a loadable ONNX Runtime library ({e}); run scripts/setup.sh (or `cargo xtask models`) to fetch it again",
                    lib.display()
                ))
            })?;
            handle
                .get::<unsafe extern "C" fn() -> *const std::ffi::c_void>(b"OrtGetApiBase\0")
                .map_err(|_| {
                    ExtractError::Runtime(format!(
                        "{}: not an ONNX Runtime library (no OrtGetApiBase)",
                        lib.display()
                    ))
                })?;
        }
        ort::init_from(lib.to_string_lossy().to_string())
            .with_name("eyereplay")
            .commit()
            .map(|_| ())
            .map_err(ExtractError::from)
    });
    // A copy for each caller (ExtractError is not Clone: some variants hold
    // an io::Error); only `Runtime` is ever stored.
    match r {
        Ok(()) => Ok(()),
        Err(ExtractError::Runtime(m)) => Err(ExtractError::Runtime(m.clone())),
        Err(e) => Err(ExtractError::Runtime(e.to_string())),
    }
}

/// Where the networks run.
///
/// The CPU is the default even where a GPU is present: these networks are
/// so small (about 0.1-0.25 GFLOP an inference) that the CUDA execution
/// provider's per-inference launch, copy and synchronisation cost exceeds
/// the CPU's whole inference. Measured on an NVIDIA H200 with onnxruntime-gpu
/// 1.31.1 (docs/EXTRACTION.md, "Where extraction's CPU time goes"): 2.2-2.5x the wall time
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

pub use eyereplay_core::LandmarkModel;

/// The networks for reading a real video (`eyereplay extract`, the
/// Python `extract()`): the one asked for, else the attention mesh
/// unless an option only the cascade has was set. The attention mesh is
/// MediaPipe's own network and half its CPU time, so a reading of real
/// video agrees with the peer tool; [`LandmarkModel::default`] stays the
/// cascade because reading rendered video back (the probes, the
/// read-back match, the report) needs its finer vertical reading of
/// small drawn movements (docs/EXTRACTION.md).
///
/// `cascade_options` names each cascade-only option as the caller spells
/// it, with whether it was set; one set with the attention mesh asked for
/// is an error, never silently dropped, whose hint is `cascade`, the
/// caller's way of asking for the cascade.
pub fn landmarks_for_real_video(
    requested: Option<LandmarkModel>,
    cascade_options: &[(&'static str, bool)],
    cascade: &'static str,
) -> Result<LandmarkModel, crate::ExtractError> {
    let set = cascade_options.iter().find(|(_, on)| *on).map(|(n, _)| *n);
    match (requested, set) {
        (Some(LandmarkModel::Attention), Some(option)) => {
            Err(crate::ExtractError::CascadeOnly { option, cascade })
        }
        (Some(model), _) => Ok(model),
        (None, Some(_)) => Ok(LandmarkModel::Cascade),
        (None, None) => Ok(LandmarkModel::Attention),
    }
}

/// One set of sessions; each worker thread owns one.
pub struct Models {
    detector: Session,
    /// The cascade's networks, made on first use.
    mesh: Option<Session>,
    iris: Option<Session>,
    /// Loaded on first use ([`Models::attention`]).
    attention: Option<AttentionSessions>,
    dir: PathBuf,
    /// True when the networks run on CUDA: the detector's session started
    /// there and every landmark session made since too.
    pub on_cuda: bool,
}

/// The attention face mesh's two halves and where its eye crops lie.
struct AttentionSessions {
    face: Session,
    eyes: Session,
    /// The left eye's (mesh points 33..133) crop, then the right one's.
    crops: [EyeCropSpec; 2],
    /// Each eye's crop of the face model's feature map, reused from frame
    /// to frame.
    eye_in: [Vec<f32>; 2],
}

impl AttentionSessions {
    /// Both sessions (on CUDA while `on_cuda`; one that falls back to the
    /// CPU clears it) and the eye crops' metadata.
    fn load(dir: &Path, on_cuda: &mut bool) -> Result<AttentionSessions> {
        let (face, a) = session(&dir.join(ATTENTION), *on_cuda)?;
        let (eyes, b) = session(&dir.join(ATTENTION_EYES), *on_cuda)?;
        *on_cuda &= a && b;
        let path = dir.join(ATTENTION_EYES);
        let what = path.display().to_string();
        let meta = eyes.metadata()?;
        let spec = |side: &str| -> Result<EyeCropSpec> {
            let get = |key: String| -> Result<String> {
                meta.custom(&key)?.ok_or_else(|| {
                    ExtractError::Runtime(format!(
                        "{what}: no metadata {key}; run scripts/setup.sh (or `cargo xtask models`) to convert it again"
                    ))
                })
            };
            EyeCropSpec::parse(
                &get(format!("{side}.crop"))?,
                &get(format!("{side}.points"))?,
                &what,
            )
        };
        let crops = [spec("left")?, spec("right")?];
        drop(meta);
        Ok(AttentionSessions {
            face,
            eyes,
            crops,
            eye_in: [vec![], vec![]],
        })
    }
}

/// A network's output of another size than the pinned model gives: a typed
/// error instead of an index out of bounds further on.
fn expect_len(model: &str, output: &str, got: usize, expected: usize) -> Result<()> {
    if got == expected {
        Ok(())
    } else {
        Err(ExtractError::ModelOutput {
            model: model.to_string(),
            output: output.to_string(),
            got,
            expected,
        })
    }
}

/// The face detector's raw outputs on one 128-px input.
#[derive(Clone, Debug, PartialEq)]
pub struct DetectorOutput {
    /// [`DETECTOR_ANCHORS`] x [`DETECTOR_ANCHOR_VALUES`]: per anchor the box
    /// (cx, cy, w, h) and six keypoints (x, y), in input pixels relative to
    /// the anchor.
    pub regressors: Vec<f32>,
    /// Per anchor a face score logit.
    pub scores: Vec<f32>,
}

/// The face mesh's outputs on one 192-px face crop.
#[derive(Clone, Debug, PartialEq)]
pub struct FaceMeshOutput {
    /// [`FACE_MESH_LANDMARKS`] x (x, y, z) in the crop's pixels.
    pub landmarks: Vec<f32>,
    /// Face presence logit.
    pub face_flag: f32,
}

/// The iris model's outputs for one eye, each point (x, y, z) in the
/// 64x64 crop's pixels.
#[derive(Clone, Debug, PartialEq)]
pub struct IrisOutput {
    /// [`EYE_CONTOUR_POINTS`] points: the eye contour and brow.
    pub contour: Vec<f32>,
    /// [`IRIS_POINTS`] points, the centre first.
    pub iris: Vec<f32>,
}

/// What the attention face mesh reads from one 192-px face crop, in the
/// crop's pixels: the model's left eye (mesh points 33..133, on the image's
/// left in an unmirrored frontal face) first.
#[derive(Clone, Debug, PartialEq)]
pub struct AttentionOut {
    /// 468 x (x, y, z).
    pub mesh: Vec<f32>,
    /// Per eye 71 x (x, y): the iris model's contour layout (point 0 and 8
    /// the corners, 4 the lower lid's middle, 12 the upper lid's).
    pub eyes: [Vec<f32>; 2],
    /// Per eye 5 x (x, y), the centre first.
    pub irises: [Vec<f32>; 2],
    /// Face presence logit.
    pub face_logit: f32,
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

/// The session in `slot`, made from `dir`/`file` on the first call (on
/// CUDA while `on_cuda`, as [`session`]; a session that falls back to the
/// CPU clears `on_cuda`).
fn lazy_session<'a>(
    slot: &'a mut Option<Session>,
    dir: &Path,
    file: &str,
    on_cuda: &mut bool,
) -> Result<&'a mut Session> {
    if slot.is_none() {
        let (s, cuda) = session(&dir.join(file), *on_cuda)?;
        *on_cuda &= cuda;
        *slot = Some(s);
    }
    Ok(slot.as_mut().expect("made above"))
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
        // The landmark networks are made on first use: the attention mesh
        // never needs the face mesh and iris sessions, nor the cascade its.
        let (detector, on_cuda) = session(&dir.join(DETECTOR), cuda)?;
        Ok(Models {
            detector,
            mesh: None,
            iris: None,
            attention: None,
            dir: dir.to_path_buf(),
            on_cuda,
        })
    }

    /// The attention face mesh on a 1x3x192x192 input in [0, 1] (the face
    /// mesh's crop): the face model, each eye's crop of its feature map
    /// ([`EyeCropSpec::matrix`], [`EyeCropSpec::crop`]), the eye model on
    /// both, their points back in the face crop. Its sessions are made on
    /// the first call, on the device the other networks run on.
    pub fn attention(&mut self, input: &[f32]) -> Result<AttentionOut> {
        if self.attention.is_none() {
            self.attention = Some(AttentionSessions::load(&self.dir, &mut self.on_cuda)?);
        }
        let att = self.attention.as_mut().expect("made above");
        let t = TensorRef::from_array_view(([1usize, 3, 192, 192], input))?;
        let out = att.face.run(ort::inputs!["input" => t])?;
        let mesh = out["output_mesh_identity_flat"]
            .try_extract_tensor::<f32>()?
            .1
            .to_vec();
        expect_len(
            ATTENTION,
            "output_mesh_identity_flat",
            mesh.len(),
            FACE_MESH_LANDMARKS * 3,
        )?;
        let flag = out["conv_faceflag_flat"].try_extract_tensor::<f32>()?.1;
        expect_len(ATTENTION, "conv_faceflag_flat", flag.len(), 1)?;
        let face_logit = flag[0];
        let (shape, map) = out["eye_features"].try_extract_tensor::<f32>()?;
        if shape.len() != 4 {
            return Err(ExtractError::Runtime(format!(
                "{ATTENTION}: output eye_features has {} dimensions, expected 4 (NCHW); \
                 run scripts/setup.sh (or `cargo xtask models`) to convert it again",
                shape.len()
            )));
        }
        let [_, c, h, w] = [0, 1, 2, 3].map(|k| shape[k] as usize);
        let matrices = [att.crops[0].matrix(&mesh), att.crops[1].matrix(&mesh)];
        for ((spec, m), input) in att.crops.iter().zip(&matrices).zip(&mut att.eye_in) {
            let [ow, oh] = spec.output;
            input.resize(c * ow * oh, 0.0);
            spec.crop(map, c, h, w, m, input);
        }
        drop(out);
        let [ow, oh] = att.crops[0].output;
        let [rw, rh] = att.crops[1].output;
        let left = TensorRef::from_array_view(([1usize, c, oh, ow], &att.eye_in[0][..]))?;
        let right = TensorRef::from_array_view(([1usize, c, rh, rw], &att.eye_in[1][..]))?;
        let out = att
            .eyes
            .run(ort::inputs!["left_eye_features" => left, "right_eye_features" => right])?;
        // Each eye model output, checked against its (x, y) point count.
        let local = |name: &str, points: usize| -> Result<Vec<f32>> {
            let v = out[name].try_extract_tensor::<f32>()?.1.to_vec();
            expect_len(ATTENTION_EYES, name, v.len(), points * 2)?;
            Ok(v)
        };
        let back = |k: usize, pts: Vec<f32>| att.crops[k].points_back(&pts, &matrices[k]);
        Ok(AttentionOut {
            eyes: [
                back(0, local("left_eye", EYE_CONTOUR_POINTS)?),
                back(1, local("right_eye", EYE_CONTOUR_POINTS)?),
            ],
            irises: [
                back(0, local("left_iris", IRIS_POINTS)?),
                back(1, local("right_iris", IRIS_POINTS)?),
            ],
            mesh,
            face_logit,
        })
    }

    /// Face detector on a 1x3x128x128 input in [-1, 1]: regressors
    /// ([`DETECTOR_ANCHORS`] x [`DETECTOR_ANCHOR_VALUES`]) and score logits
    /// (one per anchor).
    pub fn detect(&mut self, input: &[f32]) -> Result<DetectorOutput> {
        let t = TensorRef::from_array_view(([1usize, 3, 128, 128], input))?;
        let out = self.detector.run(ort::inputs!["input" => t])?;
        let (_, reg) = out["regressors"].try_extract_tensor::<f32>()?;
        let (_, sc) = out["classificators"].try_extract_tensor::<f32>()?;
        expect_len(
            DETECTOR,
            "regressors",
            reg.len(),
            DETECTOR_ANCHORS * DETECTOR_ANCHOR_VALUES,
        )?;
        expect_len(DETECTOR, "classificators", sc.len(), DETECTOR_ANCHORS)?;
        Ok(DetectorOutput {
            regressors: reg.to_vec(),
            scores: sc.to_vec(),
        })
    }

    /// Face mesh on a 1x3x192x192 input in [0, 1]: [`FACE_MESH_LANDMARKS`]
    /// x (x, y, z) in crop pixels and the face presence logit.
    pub fn mesh(&mut self, input: &[f32]) -> Result<FaceMeshOutput> {
        let t = TensorRef::from_array_view(([1usize, 3, 192, 192], input))?;
        let mesh = lazy_session(&mut self.mesh, &self.dir, MESH, &mut self.on_cuda)?;
        let out = mesh.run(ort::inputs!["input" => t])?;
        let (_, lm) = out["conv2d_21_flat"].try_extract_tensor::<f32>()?;
        let (_, sc) = out["conv2d_31_flat"].try_extract_tensor::<f32>()?;
        expect_len(MESH, "conv2d_21_flat", lm.len(), FACE_MESH_LANDMARKS * 3)?;
        expect_len(MESH, "conv2d_31_flat", sc.len(), 1)?;
        Ok(FaceMeshOutput {
            landmarks: lm.to_vec(),
            face_flag: sc[0],
        })
    }

    /// Iris model on one eye (a 1x3x64x64 input in [0, 1]). The pipeline
    /// batches both eyes ([`Models::iris`]); this is the unbatched
    /// reference the batch must equal.
    pub fn iris_single(&mut self, input: &[f32]) -> Result<IrisOutput> {
        let t = TensorRef::from_array_view(([1usize, 3, 64, 64], input))?;
        let iris = lazy_session(&mut self.iris, &self.dir, IRIS, &mut self.on_cuda)?;
        let out = iris.run(ort::inputs!["input" => t])?;
        let (_, contour) = out["output_eyes_contours_and_brows"].try_extract_tensor::<f32>()?;
        let (_, iris) = out["output_iris"].try_extract_tensor::<f32>()?;
        check_iris_lens(contour.len(), iris.len(), 1)?;
        Ok(IrisOutput {
            contour: contour.to_vec(),
            iris: iris.to_vec(),
        })
    }

    /// Iris model on both eyes at once (a 2x3x64x64 batch in [0, 1]): one
    /// inference instead of two halves the per-run overhead of ONNX Runtime.
    pub fn iris(&mut self, input: &[f32]) -> Result<[IrisOutput; 2]> {
        let mut out = self.iris_batch(&input[..2 * 3 * 64 * 64], 2)?;
        let second = out.pop().expect("two eyes");
        let first = out.pop().expect("two eyes");
        Ok([first, second])
    }

    /// Iris model on `eyes` crops at once (an `eyes`x3x64x64 batch in [0, 1],
    /// `input` exactly that long): one output per crop, in order.
    ///
    /// On the CPU the batch runs [`IRIS_CPU_BATCH`] crops at a time: ONNX
    /// Runtime's cost per crop grows past that, and each crop's output is
    /// the same to the bit whatever batch it ran in.
    pub fn iris_batch(&mut self, input: &[f32], eyes: usize) -> Result<Vec<IrisOutput>> {
        let plane = 3 * 64 * 64;
        expect_len(IRIS, "input", input.len(), eyes * plane)?;
        let iris = lazy_session(&mut self.iris, &self.dir, IRIS, &mut self.on_cuda)?;
        let step = if self.on_cuda {
            eyes.max(1)
        } else {
            IRIS_CPU_BATCH
        };
        let mut outputs = Vec::with_capacity(eyes);
        for chunk in input.chunks(step * plane) {
            let n = chunk.len() / plane;
            let t = TensorRef::from_array_view(([n, 3, 64, 64], chunk))?;
            let out = iris.run(ort::inputs!["input" => t])?;
            let (_, contour) = out["output_eyes_contours_and_brows"].try_extract_tensor::<f32>()?;
            let (_, points) = out["output_iris"].try_extract_tensor::<f32>()?;
            check_iris_lens(contour.len(), points.len(), n)?;
            outputs.extend(
                contour
                    .chunks_exact(EYE_CONTOUR_POINTS * 3)
                    .zip(points.chunks_exact(IRIS_POINTS * 3))
                    .map(|(c, i)| IrisOutput {
                        contour: c.to_vec(),
                        iris: i.to_vec(),
                    }),
            );
        }
        Ok(outputs)
    }
}

/// The iris model's two outputs for `eyes` crops: (x, y, z) per point.
fn check_iris_lens(contour: usize, iris: usize, eyes: usize) -> Result<()> {
    expect_len(
        IRIS,
        "output_eyes_contours_and_brows",
        contour,
        eyes * EYE_CONTOUR_POINTS * 3,
    )?;
    expect_len(IRIS, "output_iris", iris, eyes * IRIS_POINTS * 3)
}

#[cfg(test)]
mod tests {
    use super::landmarks_for_real_video;
    use super::LandmarkModel::{self, Attention, Cascade};

    fn choose(
        requested: Option<LandmarkModel>,
        views: bool,
        mesh: bool,
    ) -> Result<LandmarkModel, String> {
        landmarks_for_real_video(
            requested,
            &[("--iris-views", views), ("--mesh-every", mesh)],
            "--landmarks cascade",
        )
        .map_err(|e| e.to_string())
    }

    #[test]
    fn real_video_reads_with_the_attention_mesh_unless_told_otherwise() {
        assert_eq!(choose(None, false, false), Ok(Attention));
        assert_eq!(choose(Some(Cascade), false, false), Ok(Cascade));
        assert_eq!(choose(Some(Attention), false, false), Ok(Attention));
        // A cascade-only option says which networks are meant.
        assert_eq!(choose(None, true, false), Ok(Cascade));
        assert_eq!(choose(None, false, true), Ok(Cascade));
        assert_eq!(choose(Some(Cascade), true, true), Ok(Cascade));
        // The library's own default, which reads rendered video back, is
        // the cascade.
        assert_eq!(LandmarkModel::default(), Cascade);
    }

    #[test]
    fn a_cascade_option_asked_of_the_attention_mesh_is_refused_by_name() {
        let e = choose(Some(Attention), false, true).unwrap_err();
        assert!(e.starts_with("--mesh-every applies to the cascade"), "{e}");
        assert!(
            e.ends_with("use --landmarks cascade, or leave --mesh-every out"),
            "{e}"
        );
        assert!(!e.contains('\n'), "{e}");
        let e = choose(Some(Attention), true, true).unwrap_err();
        assert!(e.starts_with("--iris-views applies"), "{e}");
    }

    #[test]
    fn the_networks_fingerprint_follows_the_files_not_the_folder() {
        use super::{networks_fingerprint, NETWORKS};
        let root = tempfile::tempdir().unwrap();
        let folder = |name: &str, last_byte: u8| {
            let dir = root.path().join(name);
            std::fs::create_dir(&dir).unwrap();
            for (i, file) in NETWORKS.iter().enumerate() {
                let mut bytes = vec![i as u8; 1000];
                bytes.push(last_byte);
                std::fs::write(dir.join(file), bytes).unwrap();
            }
            dir
        };
        let (a, same, other) = (folder("a", 0), folder("b", 0), folder("c", 1));
        let empty = root.path().join("empty");
        std::fs::create_dir(&empty).unwrap();
        let fa = networks_fingerprint(&a).unwrap();
        assert_eq!(fa.len(), 12);
        assert!(fa.bytes().all(|b| b.is_ascii_hexdigit()), "{fa}");
        // The same bytes in another folder: the same rows, so the same key.
        assert_eq!(fa, networks_fingerprint(&same).unwrap());
        // One byte of one network changed, or the networks absent: not.
        assert_ne!(fa, networks_fingerprint(&other).unwrap());
        assert_ne!(fa, networks_fingerprint(&empty).unwrap());
        // Asked again, the answer stands (it is hashed once per folder).
        assert_eq!(fa, networks_fingerprint(&a).unwrap());
    }
}
