//! `eyereplay._native`: the `eyereplay` library's pipeline for Python.
//!
//! This module is deliberately thin: each function parses its arguments,
//! releases the GIL, calls one function of the Rust library and turns the
//! result into plain Python values (str, int, float, list, dict). The
//! Python half of the package (`python/eyereplay`) turns those into numpy
//! arrays, pandas frames and torch datasets, so this crate needs neither
//! numpy's C API nor torch.

use eyereplay::prepare_stages::PrepareError;
use eyereplay::{DatasetConfig, Error, EvaluateOptions, Progress, Stage, VisualChoice};
use eyereplay_extract as ex;
use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::path::{Path, PathBuf};

create_exception!(
    eyereplay,
    EyereplayError,
    PyException,
    "Base class of eyereplay's errors. The message is one line that names the file or setting at fault, as the command line prints it."
);
create_exception!(
    eyereplay,
    ConfigError,
    EyereplayError,
    "A dataset config (file or dict) or an option is invalid."
);
create_exception!(
    eyereplay,
    SourceError,
    EyereplayError,
    "A gaze source (CSV, EyeLink, BIDS, fixation report, extraction) is missing or unreadable, or too short for its class."
);
create_exception!(
    eyereplay,
    VideoError,
    EyereplayError,
    "A video cannot be decoded, has no face, or cannot be rendered or encoded."
);
create_exception!(
    eyereplay,
    ModelError,
    EyereplayError,
    "The face/iris models or the ONNX Runtime library are missing or do not match their pinned sha256 (the package ships them; $EYEREPLAY_MODELS or $EYEREPLAY_ORT_LIB may name others), or a detector model file is missing or not one this eyereplay reads."
);
create_exception!(
    eyereplay,
    DatasetError,
    EyereplayError,
    "A dataset folder is incomplete, of another format version, or inconsistent."
);

/// Which exception class an error becomes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Config,
    Source,
    Video,
    Model,
    Dataset,
    Other,
}

/// The models missing, damaged or unverifiable, or their runtime.
fn is_model_error(x: &ex::ExtractError) -> bool {
    use ex::ExtractError as X;
    matches!(
        x,
        X::ModelsMissing { .. }
            | X::ModelChecksum { .. }
            | X::ModelUnverified { .. }
            | X::Runtime(_)
    )
}

fn kind_of(e: &Error) -> Kind {
    match e {
        Error::Setting(_) | Error::Prepare(PrepareError::Config { .. }) => Kind::Config,
        Error::Prepare(_) | Error::Source(_) => Kind::Source,
        Error::Extract(x) if is_model_error(x) => Kind::Model,
        Error::Extract(_) | Error::Render(_) | Error::Face(_) | Error::Replay(_) => Kind::Video,
        Error::Backend(b) => {
            use eyereplay::backends::BackendError as B;
            match b {
                B::Setting(_) => Kind::Config,
                B::Extract(x) if is_model_error(x) => Kind::Model,
                B::Dataset(_) | B::Eval(_) | B::SessionsFailed(_) | B::UnreadableSessions(_) => {
                    Kind::Dataset
                }
                B::Core(_) | B::Input { .. } => Kind::Other,
                _ => Kind::Video,
            }
        }
        Error::Dataset(_) | Error::Eval(_) => Kind::Dataset,
        Error::Core(_) | Error::Input { .. } | Error::Detect(_) => Kind::Other,
    }
}

fn raise(kind: Kind, message: String) -> PyErr {
    match kind {
        Kind::Config => ConfigError::new_err(message),
        Kind::Source => SourceError::new_err(message),
        Kind::Video => VideoError::new_err(message),
        Kind::Model => ModelError::new_err(message),
        Kind::Dataset => DatasetError::new_err(message),
        Kind::Other => EyereplayError::new_err(message),
    }
}

fn py_err(e: Error) -> PyErr {
    raise(kind_of(&e), e.to_string())
}

/// Errors of a call that writes or reads the dataset folder `dataset`
/// (`generate`, `evaluate`, `merge`): a file there that is missing or
/// wrong, or the folder itself, is the dataset's fault ([`DatasetError`]);
/// a video named by the caller (`evaluate(video=...)`) the video's; any
/// other keeps its class.
fn dataset_err(e: Error, dataset: &Path, video: Option<&Path>) -> PyErr {
    let kind = match (kind_of(&e), &e) {
        (Kind::Other, Error::Input { path, .. }) if Some(path.as_path()) == video => Kind::Video,
        (Kind::Other, Error::Input { path, .. }) if path.starts_with(dataset) => Kind::Dataset,
        (Kind::Other, Error::Core(_)) => Kind::Dataset,
        (kind, _) => kind,
    };
    raise(kind, e.to_string())
}

/// Errors while checking a job's config: a bad `[render]` table or a
/// setting the renderer refuses is the config's fault, whatever layer
/// noticed it.
fn plan_err(e: Error, config_label: &Path) -> PyErr {
    let kind = match &e {
        Error::Dataset(_) => Kind::Config,
        Error::Input { path, .. } if path == config_label => Kind::Config,
        _ => kind_of(&e),
    };
    raise(kind, e.to_string())
}

/// Forwards the library's progress events to a Python object with the
/// methods `begin(stage, total)`, `add_total(n)`, `advance(n)`,
/// `status(text)`, `end(stage)`, `info(line)` and `warn(line)`. Called from
/// worker threads; each call takes the GIL for the duration of the call. An
/// exception in a callback is reported once, as unraisable, and the object
/// is not called again; the work goes on (a broken bar printed one
/// traceback an event, dozens a run). The frames path in Python does the
/// same (`_progress.guarded`).
struct PyProgress {
    obj: Option<Py<PyAny>>,
    broken: std::sync::atomic::AtomicBool,
}

impl PyProgress {
    fn new(obj: Option<Py<PyAny>>) -> PyProgress {
        PyProgress {
            obj,
            broken: std::sync::atomic::AtomicBool::new(false),
        }
    }
}

macro_rules! notify {
    ($self:ident, $method:literal, $args:expr) => {
        if let Some(obj) = &$self.obj {
            use std::sync::atomic::Ordering;
            if !$self.broken.load(Ordering::Relaxed) {
                Python::with_gil(|py| {
                    if let Err(e) = obj.call_method1(py, $method, $args) {
                        if !$self.broken.swap(true, Ordering::Relaxed) {
                            e.write_unraisable(py, None);
                        }
                    }
                })
            }
        }
    };
}

fn stage_name(s: Stage) -> &'static str {
    match s {
        Stage::Extract => "extract",
        Stage::Render => "render",
    }
}

impl Progress for PyProgress {
    fn begin(&self, stage: Stage, total: u64) {
        notify!(self, "begin", (stage_name(stage), total));
    }
    fn add_total(&self, units: u64) {
        notify!(self, "add_total", (units,));
    }
    fn advance(&self, units: u64) {
        notify!(self, "advance", (units,));
    }
    fn status(&self, text: &str) {
        notify!(self, "status", (text,));
    }
    fn end(&self, stage: Stage) {
        notify!(self, "end", (stage_name(stage),));
    }
    fn info(&self, line: &str) {
        notify!(self, "info", (line,));
    }
    fn warn(&self, line: &str) {
        notify!(self, "warn", (line,));
    }
}

/// The extractor's per-video events, summed into one frame count.
impl ex::Progress for PyProgress {
    fn start(&self, _video: usize, frames: Option<u64>) {
        if let Some(n) = frames {
            Progress::add_total(self, n);
        }
    }
    fn advance(&self, _video: usize, n: u64) {
        Progress::advance(self, n);
    }
}

/// Runs `work` with the GIL released, as `allow_threads` does, but on a
/// thread of its own while this one, the caller's, looks for Python's
/// signals every 100 ms: Python runs its Ctrl-C handler (a terminal's
/// Ctrl-C, a notebook's interrupt) only on the main thread, and only when
/// that thread runs Python code, so a render or an extraction of minutes
/// could not be interrupted at all. On a signal the work is asked to stop
/// ([`eyereplay_core::cancel`]; it stops at its next frame, removing what
/// it was writing), waited for, and the signal's exception
/// (`KeyboardInterrupt`) is raised instead of its result.
fn interruptible<T: Send>(py: Python<'_>, work: impl FnOnce() -> T + Send) -> PyResult<T> {
    use std::sync::mpsc;
    std::thread::scope(|scope| {
        let (done_tx, mut done_rx) = mpsc::channel::<()>();
        let worker = scope.spawn(move || {
            let out = work();
            let _ = done_tx.send(());
            out
        });
        let finished = |worker: std::thread::ScopedJoinHandle<'_, T>| {
            worker
                .join()
                .unwrap_or_else(|panic| std::panic::resume_unwind(panic))
        };
        loop {
            // The receiver goes into the GIL-free closure and comes back.
            let (waited, rx) = py.allow_threads(move || {
                let w = done_rx.recv_timeout(std::time::Duration::from_millis(100));
                (w, done_rx)
            });
            done_rx = rx;
            // A worker that panicked drops its sender: done, too.
            if !matches!(waited, Err(mpsc::RecvTimeoutError::Timeout)) {
                return Ok(finished(worker));
            }
            if let Err(signal) = py.check_signals() {
                eyereplay_core::cancel::request();
                let _ = py.allow_threads(|| worker.join());
                eyereplay_core::cancel::clear();
                return Err(signal);
            }
        }
    })
}

/// A config from a TOML file, or from TOML text (a Python dict, converted
/// by the Python side) that errors call `label`.
fn load_config(
    path: Option<PathBuf>,
    text: Option<String>,
    label: &str,
    base_dir: Option<PathBuf>,
) -> PyResult<(DatasetConfig, PathBuf)> {
    match (path, text) {
        (Some(p), None) => DatasetConfig::load(&p)
            .map(|c| (c, p))
            .map_err(|e| py_err(e.into())),
        (None, Some(t)) => {
            let label = PathBuf::from(label);
            let base = match base_dir {
                Some(b) => b,
                None => std::env::current_dir()
                    .map_err(|e| EyereplayError::new_err(format!("current folder: {e}")))?,
            };
            DatasetConfig::from_text(&t, &label, &base)
                .map(|c| (c, label))
                .map_err(|e| match e {
                    // Positions in TOML text the user never saw mean
                    // nothing; the message names the key.
                    PrepareError::Config { path, message } => ConfigError::new_err(format!(
                        "{}: {}",
                        path.display(),
                        without_position(&message)
                    )),
                    e => py_err(e.into()),
                })
        }
        _ => Err(ConfigError::new_err(
            "give a config as a TOML path or as a dict, not both or neither",
        )),
    }
}

/// `message` without a leading "line N, column M: ".
fn without_position(message: &str) -> &str {
    match message.split_once(": ") {
        Some((pos, rest)) if pos.starts_with("line ") && pos.contains(", column ") => rest,
        _ => message,
    }
}

/// A JSON object (a Python dict serialized by the Python side) as TOML
/// text, so a dict config goes through exactly the parser and messages of
/// a config file.
#[pyfunction]
fn json_to_toml(label: &str, json: &str) -> PyResult<String> {
    let bad = |m: String| ConfigError::new_err(format!("{label}: {m}"));
    let value: serde_json::Value = serde_json::from_str(json).map_err(|e| bad(e.to_string()))?;
    let table = toml::Value::try_from(value).map_err(|e| {
        bad(format!(
            "cannot be written as TOML ({e}; None values are not allowed, leave the key out)"
        ))
    })?;
    toml::to_string(&table).map_err(|e| bad(e.to_string()))
}

fn device_of(name: &str) -> PyResult<ex::Device> {
    match name {
        "auto" => Ok(ex::Device::Auto),
        "cpu" => Ok(ex::Device::Cpu),
        "cuda" => Ok(ex::Device::Cuda),
        other => Err(ConfigError::new_err(format!(
            "device '{other}': expected 'auto', 'cpu' or 'cuda'"
        ))),
    }
}

/// Stage 1 on each video: the per-frame CSV text exactly as `eyereplay
/// extract` writes it, and the summary line's numbers; with `out`, the CSVs
/// are also saved where the command would put them (atomically).
#[pyfunction]
#[pyo3(signature = (videos, out=None, models=None, threads=0, blink_ratio=ex::DEFAULT_BLINK_RATIO,
    max_seconds=None, mesh_every=None, iris_views=1, device="cpu", landmarks=None,
    progress=None))]
#[allow(clippy::too_many_arguments)]
fn extract<'py>(
    py: Python<'py>,
    videos: Vec<PathBuf>,
    out: Option<PathBuf>,
    models: Option<PathBuf>,
    threads: usize,
    blink_ratio: f64,
    max_seconds: Option<f64>,
    mesh_every: Option<u32>,
    iris_views: usize,
    device: &str,
    landmarks: Option<&str>,
    progress: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyList>> {
    let opts = extract_options(
        models,
        threads,
        blink_ratio,
        max_seconds,
        mesh_every,
        iris_views,
        device,
        landmarks,
    )?;
    // Where each CSV goes, checked before any work (as the command does).
    let csv_paths = match &out {
        Some(o) => Some(
            ex::output_csv_paths(o, &videos).map_err(|e| ConfigError::new_err(e.to_string()))?,
        ),
        None => None,
    };
    let progress = PyProgress::new(progress);
    Progress::begin(&progress, Stage::Extract, 0);
    let results = interruptible(py, || ex::extract_many(&videos, &opts, &progress))?;
    Progress::end(&progress, Stage::Extract);
    let mut failed: Vec<(Kind, String)> = vec![];
    let out = PyList::empty(py);
    for (k, res) in results.into_iter().enumerate() {
        let x = match res {
            Ok(x) => x,
            Err(e) => {
                let e = Error::from(e);
                failed.push((kind_of(&e), e.to_string()));
                continue;
            }
        };
        if let Some(paths) = &csv_paths {
            ex::save_csv(&paths[k], &x.rows).map_err(|e| py_err(Error::from(e)))?;
        }
        let mut csv = Vec::new();
        ex::write_csv(&mut csv, &x.rows).map_err(|e| EyereplayError::new_err(e.to_string()))?;
        let d = PyDict::new(py);
        d.set_item("path", &x.path)?;
        d.set_item("csv", String::from_utf8_lossy(&csv))?;
        d.set_item("frames", x.rows.len())?;
        d.set_item("width", x.info.width)?;
        d.set_item("height", x.info.height)?;
        d.set_item("codec", &x.info.codec)?;
        d.set_item("detection_rate", x.detection_rate())?;
        d.set_item("valid_frames", x.valid_frames())?;
        d.set_item("blinks", x.blinks)?;
        d.set_item("decode_errors", x.decode_errors)?;
        d.set_item("warnings", &x.warnings)?;
        d.set_item("on_cuda", x.on_cuda)?;
        out.append(d)?;
    }
    match failed.len() {
        0 => Ok(out),
        1 => {
            let (kind, msg) = failed.remove(0);
            Err(raise(kind, msg))
        }
        n => Err(raise(
            failed[0].0,
            format!(
                "{n} of {} videos failed: {}",
                videos.len(),
                failed
                    .iter()
                    .map(|f| f.1.as_str())
                    .collect::<Vec<_>>()
                    .join("; ")
            ),
        )),
    }
}

/// Options of an extraction, as `extract` takes them.
#[allow(clippy::too_many_arguments)]
fn extract_options(
    models: Option<PathBuf>,
    threads: usize,
    blink_ratio: f64,
    max_seconds: Option<f64>,
    mesh_every: Option<u32>,
    iris_views: usize,
    device: &str,
    landmarks: Option<&str>,
) -> PyResult<ex::ExtractOptions> {
    let requested = landmarks
        .map(str::parse::<ex::LandmarkModel>)
        .transpose()
        .map_err(ConfigError::new_err)?;
    let landmarks = ex::landmarks_for_real_video(
        requested,
        &[
            ("iris_views", iris_views > 1),
            ("mesh_every", mesh_every.is_some()),
        ],
        "landmarks=\"cascade\"",
    )
    .map_err(|e| ConfigError::new_err(e.to_string()))?;
    let opts = ex::ExtractOptions {
        models_dir: models.unwrap_or_else(ex::default_models_dir),
        threads,
        blink_ratio,
        max_duration_s: max_seconds,
        preview_dir: None,
        preview_every_s: 5.0,
        mesh_every: mesh_every.unwrap_or(ex::DEFAULT_MESH_EVERY),
        iris_views,
        profile: false,
        device: device_of(device)?,
        landmarks,
    };
    // The library's ranges, checked before a model loads.
    opts.validate()
        .map_err(|e| ConfigError::new_err(e.to_string()))?;
    Ok(opts)
}

/// Extraction from frames in memory (`eyereplay.extract(frames, fps=..)`):
/// the Python side feeds chunks of packed RGB frames with their times, so
/// a long clip never needs a second copy of itself.
#[pyclass]
struct FrameExtractor {
    stream: Option<ex::FrameStream>,
    width: usize,
    height: usize,
}

fn frames_err(e: ex::ExtractError) -> PyErr {
    match e {
        ex::ExtractError::Frames(_) => ConfigError::new_err(e.to_string()),
        e => py_err(Error::from(e)),
    }
}

#[pymethods]
impl FrameExtractor {
    #[new]
    #[pyo3(signature = (width, height, models=None, blink_ratio=ex::DEFAULT_BLINK_RATIO,
        mesh_every=None, iris_views=1, device="cpu", landmarks=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        width: usize,
        height: usize,
        models: Option<PathBuf>,
        blink_ratio: f64,
        mesh_every: Option<u32>,
        iris_views: usize,
        device: &str,
        landmarks: Option<&str>,
    ) -> PyResult<Self> {
        let opts = extract_options(
            models,
            1,
            blink_ratio,
            None,
            mesh_every,
            iris_views,
            device,
            landmarks,
        )?;
        let stream = py
            .allow_threads(|| ex::FrameStream::new(&opts, width, height))
            .map_err(frames_err)?;
        Ok(FrameExtractor {
            stream: Some(stream),
            width,
            height,
        })
    }

    /// Reads `len(times)` frames packed in `data` (RGB, row after row).
    fn push(&mut self, py: Python<'_>, data: &[u8], times: Vec<f64>) -> PyResult<()> {
        let stream = self
            .stream
            .as_mut()
            .ok_or_else(|| ConfigError::new_err("frames: this extraction is finished"))?;
        let frame = self.width * self.height * 3;
        if data.len() != frame * times.len() {
            return Err(ConfigError::new_err(format!(
                "frames: {} bytes for {} frames of {}x{} RGB ({} bytes each)",
                data.len(),
                times.len(),
                self.width,
                self.height,
                frame
            )));
        }
        py.allow_threads(|| {
            for (k, &t) in times.iter().enumerate() {
                stream.push_rgb(&data[k * frame..(k + 1) * frame], t)?;
            }
            Ok(())
        })
        .map_err(frames_err)
    }

    /// The rows as `eyereplay extract` writes them, and the summary.
    fn finish<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let stream = self
            .stream
            .take()
            .ok_or_else(|| ConfigError::new_err("frames: this extraction is finished"))?;
        let x = stream.finish().map_err(frames_err)?;
        let mut csv = Vec::new();
        ex::write_csv(&mut csv, &x.rows).map_err(|e| EyereplayError::new_err(e.to_string()))?;
        let valid = x.rows.iter().filter(|r| r.valid()).count();
        let d = PyDict::new(py);
        d.set_item("path", py.None())?;
        d.set_item("csv", String::from_utf8_lossy(&csv))?;
        d.set_item("frames", x.rows.len())?;
        d.set_item("width", self.width)?;
        d.set_item("height", self.height)?;
        d.set_item("codec", "rgb24 (in memory)")?;
        d.set_item(
            "detection_rate",
            x.face_frames as f64 / x.rows.len().max(1) as f64,
        )?;
        d.set_item("valid_frames", valid)?;
        d.set_item("blinks", x.blinks)?;
        d.set_item("decode_errors", 0)?;
        d.set_item("on_cuda", false)?;
        Ok(d)
    }
}

/// The reading detector on a video, an `eyereplay extract` CSV or a
/// session CSV (`eyereplay detect`): the detection as JSON, as the
/// command writes it.
#[pyfunction]
#[pyo3(signature = (input, model, cache=None, progress=None))]
fn detect(
    py: Python<'_>,
    input: PathBuf,
    model: PathBuf,
    cache: Option<PathBuf>,
    progress: Option<Py<PyAny>>,
) -> PyResult<String> {
    let cache = cache_of(cache);
    let progress = PyProgress::new(progress);
    // One class per thing at fault: the detector file is a model; the
    // input, a video or a gaze CSV, whatever layer noticed its problem
    // (missing, not a kind `detect` reads, too little gaze), except the
    // extraction's own models.
    let m = py
        .allow_threads(|| eyereplay::detect::DetectorModel::load(&model))
        .map_err(|e| ModelError::new_err(e.to_string()))?;
    let input_kind = if eyereplay::detector::is_video(&input) {
        Kind::Video
    } else {
        Kind::Source
    };
    let d = interruptible(py, || -> Result<_, Error> {
        let (track, info) = eyereplay::detector::load_track(&input, &cache, &progress)?;
        eyereplay::detector::detect_track(&track, info, &m, &model)
    })?
    .map_err(|e| match kind_of(&e) {
        Kind::Model => py_err(e),
        _ => raise(input_kind, e.to_string()),
    })?;
    serde_json::to_string(&d).map_err(|e| EyereplayError::new_err(e.to_string()))
}

/// Trains the reading detector on generated datasets (`eyereplay train`)
/// and writes the model to `out`; returns the model file's text and the
/// warnings its own figures give (too few windows, chance AUROC).
#[pyfunction]
#[pyo3(signature = (datasets, out, window_s=10.0, input="extracted", classifier="trees",
    seed=1, alpha=1.0, noise_copies=0, frame_labels=false,
    max_fpr=eyereplay::detect::model::DEFAULT_MAX_FPR, cache=None, progress=None))]
#[allow(clippy::too_many_arguments)]
fn train<'py>(
    py: Python<'py>,
    datasets: Vec<PathBuf>,
    out: PathBuf,
    window_s: f64,
    input: &str,
    classifier: &str,
    seed: u64,
    alpha: f64,
    noise_copies: usize,
    frame_labels: bool,
    max_fpr: f64,
    cache: Option<PathBuf>,
    progress: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    use eyereplay::detect::{Classifier, TrainOptions};
    use eyereplay::detector::TrainInput;
    let input = match input {
        "extracted" => TrainInput::Extracted,
        "trajectory" => TrainInput::Trajectory,
        "drawn" => TrainInput::Drawn,
        other => {
            return Err(ConfigError::new_err(format!(
                "input {other:?}: expected \"extracted\", \"trajectory\" or \"drawn\""
            )))
        }
    };
    let classifier = match classifier {
        "trees" => Classifier::BaggedTrees,
        "logistic" => Classifier::LogisticRegression,
        other => {
            return Err(ConfigError::new_err(format!(
                "classifier {other:?}: expected \"trees\" or \"logistic\""
            )))
        }
    };
    let opts = eyereplay::detector::TrainDetectorOptions {
        window_s,
        input,
        train: TrainOptions {
            classifier,
            alpha,
            seed,
            noise_copies,
            max_fpr,
            ..TrainOptions::default()
        },
        cache: cache_of(cache),
        frame_labels,
    };
    let progress = PyProgress::new(progress);
    let model = interruptible(py, || {
        eyereplay::detector::train_detector(&datasets, &opts, &progress)
    })?
    .map_err(|e| match kind_of(&e) {
        // A folder that is not a dataset, or a session in it that cannot
        // be read, is the dataset's fault.
        Kind::Other | Kind::Source => raise(Kind::Dataset, e.to_string()),
        kind => raise(kind, e.to_string()),
    })?;
    model
        .save(&out)
        .map_err(|e| EyereplayError::new_err(e.to_string()))?;
    let d = PyDict::new(py);
    d.set_item(
        "model_json",
        serde_json::to_string(&model).map_err(|e| EyereplayError::new_err(e.to_string()))?,
    )?;
    d.set_item("warnings", eyereplay::detector::training_warnings(&model))?;
    Ok(d)
}

/// Makes the models (and ONNX Runtime library) shipped inside the
/// installed package the defaults of this process (`$EYEREPLAY_MODELS`
/// and `$EYEREPLAY_ORT_LIB` still win): called once at import.
#[pyfunction]
#[pyo3(signature = (models_dir, runtime_library=None))]
fn use_package_files(models_dir: PathBuf, runtime_library: Option<PathBuf>) {
    ex::use_package_files(models_dir, runtime_library);
}

/// Makes the face mesh and photos shipped inside the installed package
/// the full-face mode's defaults (`$EYEREPLAY_CACHE/faces` still wins
/// where it holds them): called once at import.
#[pyfunction]
fn use_package_faces(faces_dir: PathBuf) {
    eyereplay_face::use_package_faces(faces_dir);
}

/// Where caches go: `$EYEREPLAY_CACHE`, else the user's cache folder
/// (`$XDG_CACHE_HOME/eyereplay` or `~/.cache/eyereplay`).
#[pyfunction]
fn cache_dir() -> PathBuf {
    eyereplay::cache_dir(None)
}

fn cache_of(cache: Option<PathBuf>) -> PathBuf {
    eyereplay::cache_dir(cache.as_deref())
}

/// Stages 2-5 and the trajectory dataset (`eyereplay prepare`).
#[pyfunction]
#[pyo3(signature = (config_path, config_toml, label, base_dir, out, cache=None, dry_run=false, progress=None))]
#[allow(clippy::too_many_arguments)]
fn prepare<'py>(
    py: Python<'py>,
    config_path: Option<PathBuf>,
    config_toml: Option<String>,
    label: &str,
    base_dir: Option<PathBuf>,
    out: Option<PathBuf>,
    cache: Option<PathBuf>,
    dry_run: bool,
    progress: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let (cfg, label) = load_config(config_path, config_toml, label, base_dir)?;
    // As `eyereplay prepare` does: a typo in `[render]` is found now, not
    // when the prepared dataset is rendered.
    eyereplay::render_table(&cfg, &label).map_err(|e| plan_err(e, &label))?;
    let cache = cache_of(cache);
    let progress = PyProgress::new(progress);
    let d = PyDict::new(py);
    let prepared = match out.filter(|_| !dry_run) {
        None => interruptible(py, || eyereplay::prepare_only(&cfg, &cache, &progress))?
            .map_err(py_err)?,
        Some(out) => {
            let ds = interruptible(py, || {
                eyereplay::prepare_dataset(&cfg, &out, &cache, &progress)
            })?
            .map_err(py_err)?;
            d.set_item("out", &out)?;
            d.set_item("files", ds.files)?;
            d.set_item("bytes", ds.bytes)?;
            ds.prepared
        }
    };
    let plan = prepared.plan(&cfg);
    d.set_item("video_hours", plan.video_hours)?;
    d.set_item("session_frames", cfg.session_frames)?;
    d.set_item("fps", cfg.fps)?;
    if let Some(c) = &prepared.calibration {
        let cal = PyDict::new(py);
        cal.set_item("s_x", c.s_x)?;
        cal.set_item("s_y", c.s_y)?;
        cal.set_item("mu_x", c.mu_x)?;
        cal.set_item("mu_y", c.mu_y)?;
        d.set_item("calibration", cal)?;
    }
    let sources = PyList::empty(py);
    for s in &prepared.sources {
        let r = PyDict::new(py);
        r.set_item("id", &s.id)?;
        r.set_item("class", s.class.name())?;
        r.set_item("rate_hz", s.rate_hz)?;
        r.set_item("samples", s.samples)?;
        r.set_item("filled", s.filled.total)?;
        r.set_item(
            "alpha",
            s.speed_correction
                .applied
                .then_some(s.speed_correction.alpha),
        )?;
        r.set_item("frames", s.frames)?;
        sources.append(r)?;
    }
    d.set_item("sources", sources)?;
    let classes = PyDict::new(py);
    for c in &prepared.classes {
        let r = PyDict::new(py);
        r.set_item("sessions", c.sessions.len())?;
        r.set_item("pool_frames", c.pool.len())?;
        r.set_item("stride", c.stride)?;
        r.set_item("reuse_ratio", c.reuse_ratio)?;
        r.set_item("speed_scale", c.speed_scale)?;
        classes.set_item(c.class.name(), r)?;
    }
    d.set_item("classes", classes)?;
    d.set_item("warnings", &prepared.warnings)?;
    Ok(d)
}

/// The whole job (`eyereplay generate`): validated first, then extract,
/// prepare, render, and (without a shard) finalize and evaluate.
#[pyfunction]
#[pyo3(signature = (config_path, config_toml, label, base_dir, out, shard=None, shards=None,
    cache=None, evaluate=true, progress=None))]
#[allow(clippy::too_many_arguments)]
fn generate<'py>(
    py: Python<'py>,
    config_path: Option<PathBuf>,
    config_toml: Option<String>,
    label: &str,
    base_dir: Option<PathBuf>,
    out: PathBuf,
    shard: Option<String>,
    shards: Option<usize>,
    cache: Option<PathBuf>,
    evaluate: bool,
    progress: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let (cfg, label) = load_config(config_path, config_toml, label, base_dir)?;
    let shard = eyereplay::Shard::resolve(shard.as_deref(), shards)
        .map_err(|e| raise(Kind::Config, e.to_string()))?;
    let cache = cache_of(cache);
    let job = interruptible(py, || eyereplay::plan_config(cfg, &label, shard, &cache))?
        .map_err(|e| plan_err(e, &label))?;
    let opts = eyereplay::GenerateOptions {
        out: out.clone(),
        shard,
        cache: Some(cache),
        evaluate: evaluate.then(EvaluateOptions::default),
    };
    let progress = PyProgress::new(progress);
    let summary = interruptible(py, || eyereplay::generate(&job, &opts, &progress))?
        .map_err(|e| dataset_err(e, &out, None))?;
    let d = PyDict::new(py);
    d.set_item("out", &out)?;
    d.set_item("rendered", summary.render.rendered)?;
    d.set_item("skipped", summary.render.skipped)?;
    d.set_item("frames", summary.render.frames)?;
    d.set_item("clamped_points", summary.render.clamped_points)?;
    d.set_item("report", summary.report.as_ref())?;
    d.set_item(
        "checks",
        summary
            .checks
            .as_ref()
            .map(|c| checks_dict(py, c))
            .transpose()?,
    )?;
    let stages = PyDict::new(py);
    for (name, s) in &summary.stage_s {
        stages.set_item(*name, *s)?;
    }
    d.set_item("stage_s", stages)?;
    Ok(d)
}

/// The evaluation report (`eyereplay evaluate`): returns the metrics.json
/// text and where the report and metrics were written.
#[pyfunction]
#[pyo3(signature = (dataset_dir, visual=true, visual_session=None, video=None, trajectory=None,
    visual_seconds=120.0, models=None, progress=None))]
#[allow(clippy::too_many_arguments)]
fn evaluate<'py>(
    py: Python<'py>,
    dataset_dir: PathBuf,
    visual: bool,
    visual_session: Option<String>,
    video: Option<PathBuf>,
    trajectory: Option<PathBuf>,
    visual_seconds: f64,
    models: Option<PathBuf>,
    progress: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let progress = PyProgress::new(progress);
    let named_video = video.clone();
    let visual = match (visual, video, trajectory, visual_session) {
        (false, ..) => VisualChoice::Skip,
        (_, Some(video), Some(trajectory), _) => VisualChoice::Video { video, trajectory },
        (_, Some(_), None, _) | (_, None, Some(_), _) => {
            return Err(ConfigError::new_err(
                "video and trajectory go together: give both or neither",
            ))
        }
        (_, None, None, Some(s)) => VisualChoice::Session(s),
        _ => VisualChoice::Auto,
    };
    let opts = EvaluateOptions {
        visual,
        visual_seconds,
        models,
        ..EvaluateOptions::default()
    };
    let outcome = interruptible(py, || {
        eyereplay::evaluate_with_progress(&dataset_dir, &opts, &progress)
    })?
    .map_err(|e| dataset_err(e, &dataset_dir, named_video.as_deref()))?;
    let d = PyDict::new(py);
    d.set_item(
        "checks",
        checks_dict(py, &eyereplay::eval::report::checks(&outcome.evaluation))?,
    )?;
    d.set_item("metrics_json", &outcome.metrics_json)?;
    d.set_item("metrics_path", &outcome.metrics_path)?;
    d.set_item("html", &outcome.html)?;
    Ok(d)
}

/// The report's summary, as `generate` and `evaluate` print it: `total`
/// checks, `passing`, the `failing` ones named (`"reading: r y 0.870 <
/// 0.95"`), and `line`, the printed sentence.
fn checks_dict<'py>(
    py: Python<'py>,
    c: &eyereplay::eval::report::Checks,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("total", c.total)?;
    d.set_item("passing", c.total - c.failing.len())?;
    d.set_item("failing", &c.failing)?;
    d.set_item("line", c.line())?;
    Ok(d)
}

/// Finishes a sharded dataset once every shard is rendered (`eyereplay merge`).
#[pyfunction]
#[pyo3(signature = (dataset_dir, evaluate=true, progress=None))]
fn merge(
    py: Python<'_>,
    dataset_dir: PathBuf,
    evaluate: bool,
    progress: Option<Py<PyAny>>,
) -> PyResult<Option<PathBuf>> {
    let progress = PyProgress::new(progress);
    let opts = evaluate.then(EvaluateOptions::default);
    let outcome = interruptible(py, || {
        eyereplay::finalize_with_progress(&dataset_dir, opts.as_ref(), &progress)
    })?
    .map_err(|e| dataset_err(e, &dataset_dir, None))?;
    Ok(outcome.map(|o| o.html))
}

/// A dataset folder's metadata.json text (format version checked) and one
/// dict per session from labels.csv with the paths of its files.
#[pyfunction]
fn dataset_index<'py>(
    py: Python<'py>,
    dataset_dir: PathBuf,
) -> PyResult<(String, Bound<'py, PyList>)> {
    use eyereplay_dataset as ds;
    let dataset_err = |e: ds::DatasetError| py_err(Error::from(e));
    let meta_path = dataset_dir.join(ds::layout::METADATA_FILE);
    let meta_text = std::fs::read_to_string(&meta_path)
        .map_err(|e| DatasetError::new_err(format!("{}: {e}", meta_path.display())))?;
    // Parsed by the typed reader for its format-version check; Python gets
    // the document as written.
    ds::parse_metadata(&meta_text, &meta_path).map_err(dataset_err)?;
    let labels = ds::read_labels(&dataset_dir).map_err(dataset_err)?;
    let paths = ds::session_paths_of(&dataset_dir, &labels);
    let rows = PyList::empty(py);
    for (row, p) in labels.iter().zip(paths) {
        let d = PyDict::new(py);
        d.set_item("file", &row.file)?;
        d.set_item("label", row.label())?;
        d.set_item("class", row.class.name())?;
        d.set_item("sources", &row.sources)?;
        d.set_item("csv", &p.csv)?;
        d.set_item("mp4", &p.mp4)?;
        d.set_item("truth", &p.truth)?;
        d.set_item("identity", &p.identity_json)?;
        rows.append(d)?;
    }
    Ok((meta_text, rows))
}

/// `eyereplay models check`: the models folder verified, one inference each.
#[pyfunction]
#[pyo3(signature = (dir=None))]
fn check_models(py: Python<'_>, dir: Option<PathBuf>) -> PyResult<Vec<String>> {
    let dir = dir.unwrap_or_else(ex::default_models_dir);
    py.allow_threads(|| ex::check_models_strict(&dir))
        .map_err(|e| py_err(Error::from(e)))
}

/// Where models are looked for: `$EYEREPLAY_MODELS`, else the ones inside
/// the installed package, else the `.cache/models` of a checkout above the
/// current folder.
#[pyfunction]
fn default_models_dir() -> PathBuf {
    ex::default_models_dir()
}

/// The bundled default config (`examples/default.toml` of a checkout above
/// the current folder), if there is one.
#[pyfunction]
fn default_config() -> Option<PathBuf> {
    eyereplay::core::find_upwards(Path::new("examples/default.toml"))
}

/// The version of the Rust library inside this wheel.
#[pyfunction]
fn version() -> &'static str {
    env!("CARGO_PKG_VERSION")
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("EyereplayError", py.get_type::<EyereplayError>())?;
    m.add("ConfigError", py.get_type::<ConfigError>())?;
    m.add("SourceError", py.get_type::<SourceError>())?;
    m.add("VideoError", py.get_type::<VideoError>())?;
    m.add("ModelError", py.get_type::<ModelError>())?;
    m.add("DatasetError", py.get_type::<DatasetError>())?;
    m.add_function(wrap_pyfunction!(json_to_toml, m)?)?;
    m.add_function(wrap_pyfunction!(extract, m)?)?;
    m.add_function(wrap_pyfunction!(prepare, m)?)?;
    m.add_function(wrap_pyfunction!(generate, m)?)?;
    m.add_function(wrap_pyfunction!(evaluate, m)?)?;
    m.add_function(wrap_pyfunction!(merge, m)?)?;
    m.add_function(wrap_pyfunction!(dataset_index, m)?)?;
    m.add_function(wrap_pyfunction!(check_models, m)?)?;
    m.add_function(wrap_pyfunction!(default_models_dir, m)?)?;
    m.add_function(wrap_pyfunction!(default_config, m)?)?;
    m.add_function(wrap_pyfunction!(version, m)?)?;
    m.add_function(wrap_pyfunction!(detect, m)?)?;
    m.add_function(wrap_pyfunction!(train, m)?)?;
    m.add_function(wrap_pyfunction!(use_package_files, m)?)?;
    m.add_function(wrap_pyfunction!(use_package_faces, m)?)?;
    m.add_function(wrap_pyfunction!(cache_dir, m)?)?;
    m.add_class::<FrameExtractor>()?;
    Ok(())
}
