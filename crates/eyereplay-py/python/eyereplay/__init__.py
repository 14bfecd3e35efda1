"""eyereplay: real human eye movements in, labeled synthetic eye-movement
video out, from Python.

The same pipeline as the ``eyereplay`` command (it is the same Rust library
inside this package), with numpy in and out::

    import eyereplay

    iris = eyereplay.extract("interview.mp4")           # per-frame table
    iris = eyereplay.extract(frames, fps=30)            # (T, H, W, 3) uint8 frames in memory
    verdict = eyereplay.detect("interview.mp4")         # is this person reading?
    eyereplay.generate("dataset.toml", "data/")         # videos, CSVs, labels, report
    ds = eyereplay.load_dataset("data/")
    ds[0].trajectory["x"], ds[0].label, ds[0].video
    metrics = eyereplay.evaluate("data/")               # the metrics.json as a dict
    torch_ds = ds.as_torch(window=250)                  # trajectory windows, or video clips

Long calls release the GIL and show a progress bar (tqdm in notebooks and
terminals when installed, else a text bar on stderr). Errors are
:class:`EyereplayError` subclasses carrying the command line's one-line
messages.
"""

from __future__ import annotations

import json
import numbers
import os
import warnings
from pathlib import Path
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from . import _native
from ._native import (
    ConfigError,
    DatasetError,
    EyereplayError,
    ModelError,
    SourceError,
    VideoError,
)
from ._errors import require as _require
from ._progress import EyereplayWarning, ProgressBar
from ._progress import guarded as _guarded
from ._progress import resolve as _resolve_progress
from ._table import parse_csv, read_csv, to_pandas
from .dataset import Dataset, Session, load_dataset

__version__ = _native.version()

_PACKAGE_DIR = Path(__file__).resolve().parent
#: The networks shipped inside this package (MediaPipe's, Apache-2.0; see
#: ``NOTICE`` beside them) and the pinned ONNX Runtime library that runs
#: them (MIT), so extraction works from any folder with no other step.
PACKAGE_MODELS = _PACKAGE_DIR / "models"
#: The default reading detector, trained by the repository's own command
#: (``scripts/run.sh``) on generated people drawn as whole faces
#: (``examples/detector/train_behaviour_face.toml``), not on the bundled
#: default dataset; :func:`train` makes one from datasets of your own.
DEFAULT_DETECTOR = _PACKAGE_DIR / "default_detector.json"
_ORT_LIB = PACKAGE_MODELS / "libonnxruntime.so.1.22.1"
if PACKAGE_MODELS.is_dir():
    _native.use_package_files(
        str(PACKAGE_MODELS), str(_ORT_LIB) if _ORT_LIB.is_file() else None
    )
#: MediaPipe's canonical face mesh (Apache-2.0) and the bundled face
#: photos (each with its license; ``NOTICE`` beside them): the full-face
#: mode's identities when a config names none.
PACKAGE_FACES = _PACKAGE_DIR / "faces"
if PACKAGE_FACES.is_dir():
    _native.use_package_faces(str(PACKAGE_FACES))

__all__ = [
    "extract",
    "extract_many",
    "detect",
    "train",
    "cache_dir",
    "prepare",
    "generate",
    "merge",
    "evaluate",
    "load_dataset",
    "Dataset",
    "Session",
    "check_models",
    "default_models_dir",
    "read_csv",
    "to_pandas",
    "ProgressBar",
    "EyereplayError",
    "ConfigError",
    "SourceError",
    "VideoError",
    "ModelError",
    "DatasetError",
    "EyereplayWarning",
    "EXTRACT_COLUMNS",
    "DEFAULT_DETECTOR",
    "PACKAGE_FACES",
    "PACKAGE_MODELS",
]

PathLike = Union[str, "os.PathLike[str]"]
# A config argument: a TOML file's path, a dict of its tables, or None.
# Private: a type alias, not a class to make instances of.
_Config = Union[PathLike, Mapping[str, Any], None]

_DICT_LABEL = "<config dict>"


def _config_args(config: _Config, base_dir: Optional[PathLike]) -> Tuple[Any, Any, str, Any]:
    """(path, toml text, label, base dir) for the native functions: a path
    is read by Rust; a dict becomes TOML text, parsed and validated by the
    same code and with the same messages as a config file."""
    if config is None:
        found = _native.default_config()
        if found is None:
            raise ConfigError(
                "no config given and examples/default.toml not found above the current folder; "
                "pass a TOML path or a dict"
            )
        return str(found), None, "", None
    if isinstance(config, Mapping):
        bad = _bad_number(config)
        if bad is not None:
            raise ConfigError(f"{_DICT_LABEL}: {bad[0]}: {bad[1]!r} is not a finite number")
        try:
            text = json.dumps(config, default=_json_value, allow_nan=False)
        except TypeError as e:
            raise ConfigError(f"{_DICT_LABEL}: {e}") from None
        toml = _native.json_to_toml(_DICT_LABEL, text)
        return None, toml, _DICT_LABEL, os.fspath(base_dir) if base_dir is not None else None
    if isinstance(config, (str, os.PathLike)):
        _require(config, ConfigError, "no such config file")
        return os.fspath(config), None, "", None
    raise ConfigError(
        f"config must be a TOML path or a dict, not {type(config).__name__}"
    )


def _json_value(v: Any) -> Any:
    """What json cannot write itself: paths, and numpy's scalars and
    arrays (``np.int64(3)``, everywhere in ML code), as their Python values."""
    if isinstance(v, os.PathLike):
        return os.fspath(v)
    if isinstance(v, np.generic):
        return v.item()
    if isinstance(v, np.ndarray):
        return v.tolist()
    raise TypeError(f"a {type(v).__name__} ({v!r:.40}) is not a config value "
                    "(strings, numbers, booleans, lists and dicts are)")


def _bad_number(d: Any, path: str = "") -> Optional[Tuple[str, Any]]:
    """The dotted key and value of the first NaN or infinite number in a
    config dict (JSON, and so TOML, has no such numbers)."""
    items = d.items() if isinstance(d, Mapping) else enumerate(d) if isinstance(d, (list, tuple)) else ()
    for k, v in items:
        key = f"{path}[{k}]" if isinstance(k, int) else f"{path}.{k}" if path else str(k)
        if isinstance(v, (float, np.floating)) and not np.isfinite(v):
            return key, v
        found = _bad_number(v, key)
        if found is not None:
            return found
    return None


def _check_whole_numbers(**values: Any) -> Dict[str, int]:
    """Each value as a Python int: numpy's integers (``np.int64(4)``, what
    array arithmetic gives) are whole numbers too; bool is not one."""
    out = {}
    for name, value in values.items():
        if not isinstance(value, numbers.Integral) or isinstance(value, (bool, np.bool_)) \
                or value < 0:
            raise ConfigError(f"{name} {value!r}: expected a whole number, 0 or more")
        out[name] = int(value)
    return out


def _require_pandas(pandas: bool) -> None:
    """``pandas=True`` without pandas fails before the work, not after it."""
    if pandas:
        try:
            import pandas as _pd  # noqa: F401
        except ImportError:
            raise ImportError(
                "pandas=True: pandas is not installed: pip install pandas "
                "(or leave pandas=False for the numpy array)"
            ) from None


def _opt_path(p: Optional[PathLike]) -> Optional[str]:
    return None if p is None else os.fspath(p)


def extract(
    video: Union[PathLike, np.ndarray],
    *,
    fps: Optional[float] = None,
    timestamps: Optional[Sequence[float]] = None,
    out: Optional[PathLike] = None,
    pandas: bool = False,
    models: Optional[PathLike] = None,
    threads: int = 0,
    blink_ratio: float = 0.6,
    max_seconds: Optional[float] = None,
    mesh_every: Optional[int] = None,
    iris_views: int = 1,
    device: str = "cpu",
    landmarks: Optional[str] = None,
    progress: Any = True,
):
    """Stage 1: the iris position in the eye aperture, one row per decoded
    frame of ``video``.

    Returns a numpy structured array with the columns of ``eyereplay
    extract``'s CSV (``frame, time_s, valid, nx, ny, blink, face, ...``;
    see :data:`EXTRACT_COLUMNS`), or a pandas DataFrame with
    ``pandas=True``. ``nx`` runs from the image-left eye corner (0) to the
    image-right one (1), ``ny`` from the upper lid (0) to the lower (1);
    ``nx_head`` is ``nx`` against eye corners carried by the head's own
    face-mesh points (the iris model's corners follow the iris, so ``nx``
    shows a little over half the eye's movement); frames without a face
    have ``valid == 0`` and NaN positions. With ``out``, the CSV is also
    written there, byte-identical to the command's.

    ``device`` is ``"cpu"`` (the default: these small networks ran slower
    on a GPU), ``"cuda"`` (with ``EYEREPLAY_ORT_LIB`` pointing at an
    onnxruntime-gpu build's ``libonnxruntime.so``) or ``"auto"`` (CUDA when
    that library has it); ``iris_views`` reads each eye from that many
    shifted crops and averages them (``--iris-views``: more precise, about
    as many times the iris model's CPU time). ``landmarks`` picks the
    networks, as ``--landmarks`` does: ``"attention"``, the default, is
    MediaPipe's attention face mesh, the network of MediaPipe's
    ``refine_landmarks=True`` (its own numbers, in about half its CPU time);
    ``"cascade"`` is the face mesh then the iris model on each eye's 64-px
    crop (finer on small eye movements, about twice the CPU time).
    ``iris_views`` above 1 and ``mesh_every`` (default 2) are the cascade's
    and select it when ``landmarks`` is not given; asked of the attention
    mesh they are a :class:`ConfigError`. The other options are the
    command's flags.
    ``video`` may also be frames in memory: a numpy array ``(T, H, W, 3)``
    of ``uint8`` RGB (OpenCV's BGR frames need ``frame[..., ::-1]``), with
    ``fps`` (frame ``k`` at ``k / fps`` s) or ``timestamps`` (seconds, one
    per frame, increasing). No video file is written. The rows are close
    to, not the same as, those of a video of the same frames: a video's
    frames are decoded from its compressed picture, these are read as
    given (on a 6 s clip the two differed by at most 0.002 in ``nx`` and
    0.01 in ``ny``).

    Raises :class:`VideoError` for an unreadable video or one with no face,
    :class:`ModelError` when the models are missing (see :func:`check_models`).
    """
    whole = _check_whole_numbers(threads=threads, iris_views=iris_views)
    threads, iris_views = whole["threads"], whole["iris_views"]
    _require_pandas(pandas)
    if isinstance(video, np.ndarray) or hasattr(video, "__array_interface__"):
        # Options of a video file, which frames in memory do not have:
        # refused rather than ignored.
        if max_seconds is not None:
            raise ConfigError("max_seconds applies to a video file; slice the frames instead")
        if threads != 0:
            raise ConfigError("threads applies to video files (one worker per video segment); "
                              "frames in memory are read in order by one")
        if out is not None and (Path(out).is_dir() or Path(out).suffix.lower() != ".csv"):
            raise ConfigError(f"out: {os.fspath(out)}: frames in memory are written to one "
                              "CSV file; name it with .csv")
        if out is not None:
            # As for a video file: the folder is made, before the work.
            Path(out).parent.mkdir(parents=True, exist_ok=True)
        t = _extract_frames(
            np.asarray(video),
            fps=fps,
            timestamps=timestamps,
            models=models,
            blink_ratio=blink_ratio,
            mesh_every=mesh_every,
            iris_views=iris_views,
            device=device,
            landmarks=landmarks,
            progress=progress,
        )
        table = t["table"]
        # As a video with no face is refused: rows that are all NaN would
        # otherwise look like an answer.
        if not np.any(table["face"] == 1):
            raise VideoError(f"frames: no face found in any of their {len(table)} frames")
        if out is not None:
            # Whole or not at all: a temporary file beside it, renamed.
            tmp = Path(out).with_name(f".{Path(out).name}.{os.getpid()}.part")
            tmp.write_text(t.pop("csv_text"))
            os.replace(tmp, out)
        else:
            t.pop("csv_text")
        return to_pandas(table) if pandas else table
    if isinstance(video, (list, tuple)):
        raise TypeError(
            "video: expected one path or a numpy uint8 array (T, H, W, 3), got a "
            f"{type(video).__name__} (extract_many takes a list of paths)"
        )
    if not isinstance(video, (str, bytes, os.PathLike)):
        raise TypeError(
            "video: expected one path or a numpy uint8 array (T, H, W, 3), got a "
            f"{type(video).__name__}"
        )
    if fps is not None or timestamps is not None:
        raise ConfigError("fps and timestamps apply to frames in memory, not to a video file")
    tables = extract_many(
        [video],
        out=out,
        pandas=pandas,
        models=models,
        threads=threads,
        blink_ratio=blink_ratio,
        max_seconds=max_seconds,
        mesh_every=mesh_every,
        iris_views=iris_views,
        device=device,
        landmarks=landmarks,
        progress=progress,
    )
    return tables[0]


#: Frames handed to the extractor at a time: bounds the copy a chunk makes.
_FRAME_CHUNK = 32


def _frame_times(n: int, fps: Optional[float], timestamps: Optional[Sequence[float]]) -> np.ndarray:
    if (fps is None) == (timestamps is None):
        raise ConfigError("frames in memory need exactly one of fps= and timestamps=")
    if timestamps is not None:
        t = np.asarray(timestamps, dtype=np.float64).reshape(-1)
        if t.shape[0] != n:
            raise ConfigError(f"timestamps: {t.shape[0]} values for {n} frames")
        if not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
            raise ConfigError("timestamps: must be finite and increasing")
        return t
    # bool is an int to Python: fps=True would be 1 frame a second.
    if isinstance(fps, (bool, np.bool_)) or not (
        isinstance(fps, numbers.Real) and np.isfinite(fps) and fps > 0
    ):
        raise ConfigError(f"fps {fps!r}: expected a positive number")
    return np.arange(n, dtype=np.float64) / float(fps)


def _extract_frames(frames: np.ndarray, *, fps, timestamps, models, blink_ratio, mesh_every,
                    iris_views, device, landmarks, progress) -> Dict[str, Any]:
    if frames.ndim != 4 or frames.shape[3] != 3:
        raise ConfigError(
            f"frames: expected an array (T, H, W, 3) of RGB, got shape {tuple(frames.shape)}"
        )
    if frames.dtype != np.uint8:
        raise ConfigError(f"frames: expected dtype uint8, got {frames.dtype}")
    n, h, w, _ = frames.shape
    if n == 0:
        raise ConfigError("frames: no frames given")
    times = _frame_times(n, fps, timestamps)
    bar = _guarded(_resolve_progress(progress))
    fx = _native.FrameExtractor(
        w, h, models=_opt_path(models), blink_ratio=blink_ratio, mesh_every=mesh_every,
        iris_views=iris_views, device=device, landmarks=landmarks,
    )
    if bar is not None:
        bar.begin("extract", n)
    for k in range(0, n, _FRAME_CHUNK):
        chunk = np.ascontiguousarray(frames[k:k + _FRAME_CHUNK])
        fx.push(chunk.tobytes(), times[k:k + _FRAME_CHUNK].tolist())
        if bar is not None:
            bar.advance(chunk.shape[0])
    if bar is not None:
        bar.end("extract")
    r = fx.finish()
    return {"table": parse_csv(r["csv"], "<frames>"), "csv_text": r["csv"]}


def detect(
    video_or_frames: Union[PathLike, np.ndarray],
    model: Optional[PathLike] = None,
    *,
    fps: Optional[float] = None,
    timestamps: Optional[Sequence[float]] = None,
    cache: Optional[PathLike] = None,
    progress: Any = True,
) -> Dict[str, Any]:
    """Is the person reading? (``eyereplay detect``). ``video_or_frames`` is
    a video, an ``eyereplay extract`` CSV, a session CSV, or frames in
    memory as for :func:`extract` (with ``fps`` or ``timestamps``).
    ``model`` is a detector file from ``eyereplay train``; by default the
    detector shipped in this package (:data:`DEFAULT_DETECTOR`). Frames are
    read with the detector's own extractor (the cascade), as a video file
    is, so the frames of a video get the video's answer.

    Returns a dict: ``verdict`` (``"reading"`` or ``"not reading"``; for a
    clip shorter than one window, ``"uncertain"`` when its interval holds
    the threshold),
    ``reading_probability`` (mean over windows), ``reading_window_fraction``,
    ``windows`` (one row per window, ``start_s, end_s,
    reading_probability, reading, forward_run_fraction``: a pandas
    DataFrame when pandas can be imported, else a numpy structured array;
    a clip shorter than one window has none, and its table only the first
    three columns), ``localization`` (when: the
    probability per second, the reading segments with start, end and
    confidence, and the stretches without enough gaze), ``clip`` (a clip
    shorter than one window: its probability with a 90 % interval, else
    ``None``), and the ``model`` and ``input`` it was made from
    (``input["frames"]`` counts the gaze resampled to the detector's 25
    frames a second, not the video's own frames).

    Raises :class:`ModelError` for a detector file that is missing or not
    one; :class:`VideoError` for a video (or frames) that cannot be read or
    shows too little gaze; :class:`SourceError` for a CSV that is not one
    ``detect`` reads or holds too little gaze.
    """
    import tempfile

    model_path = Path(model) if model is not None else DEFAULT_DETECTOR
    if not model_path.is_file():
        raise ModelError(f"{model_path}: detector model not found")
    if isinstance(video_or_frames, np.ndarray) or hasattr(video_or_frames, "__array_interface__"):
        with tempfile.TemporaryDirectory(prefix="eyereplay-detect-") as tmp:
            csv = Path(tmp) / "frames.csv"
            # The detector's extractor, as for a video file (the cascade:
            # what it was trained and measured on), so that frames and the
            # video they came from get the same answer.
            extract(video_or_frames, fps=fps, timestamps=timestamps, out=csv, landmarks="cascade",
                    progress=progress)
            try:
                d = json.loads(_native.detect(str(csv), str(model_path), cache=_opt_path(cache)))
            except EyereplayError as e:
                # The temporary CSV is ours, not the caller's: name the
                # frames, and what is wrong with them is a video's fault.
                cls = VideoError if type(e) is SourceError else type(e)
                raise cls(str(e).replace(str(csv), "frames")) from None
            d["input"]["path"] = "<frames>"
            d["input"]["kind"] = "frames"
    else:
        if not isinstance(video_or_frames, (str, os.PathLike)):
            raise TypeError(
                "video_or_frames: expected one path or a numpy uint8 array (T, H, W, 3), "
                f"got a {type(video_or_frames).__name__}"
            )
        if fps is not None or timestamps is not None:
            raise ConfigError("fps and timestamps apply to frames in memory, not to a file")
        is_csv = Path(video_or_frames).suffix.lower() == ".csv"
        _require(video_or_frames, SourceError if is_csv else VideoError,
                 "no such file" if is_csv else "cannot open video: no such file")
        d = json.loads(
            _native.detect(os.fspath(video_or_frames), str(model_path), cache=_opt_path(cache),
                           progress=_resolve_progress(progress))
        )
    rows = d.pop("windows")
    names = list(rows[0].keys()) if rows else ["start_s", "end_s", "reading_probability"]
    dtype = [(k, np.bool_ if isinstance(rows[0][k], bool) else np.float64) for k in names] if rows \
        else [(k, np.float64) for k in names]
    table = np.array([tuple(r[k] for k in names) for r in rows], dtype=dtype)
    try:
        import pandas  # noqa: F401

        d["windows"] = to_pandas(table)
    except ImportError:
        d["windows"] = table
    return d


def cache_dir() -> Path:
    """Where extractions and measurements are cached, shared with the
    command line: ``$EYEREPLAY_CACHE``, else ``$XDG_CACHE_HOME/eyereplay``,
    else ``~/.cache/eyereplay``; never the current folder."""
    return Path(_native.cache_dir())


def extract_many(
    videos: Sequence[PathLike],
    *,
    out: Optional[PathLike] = None,
    pandas: bool = False,
    models: Optional[PathLike] = None,
    threads: int = 0,
    blink_ratio: float = 0.6,
    max_seconds: Optional[float] = None,
    mesh_every: Optional[int] = None,
    iris_views: int = 1,
    device: str = "cpu",
    landmarks: Optional[str] = None,
    progress: Any = True,
) -> list:
    """:func:`extract` on several videos at once (in parallel), one table
    each in the order given. ``out`` is a ``.csv`` file for one video or a
    folder that gets ``<video stem>.csv`` for each."""
    if isinstance(videos, (str, bytes, os.PathLike)):
        raise TypeError(
            f"videos: expected a list of paths, got one {type(videos).__name__} "
            "(extract takes a single video)"
        )
    for v in videos:
        if not isinstance(v, (str, bytes, os.PathLike)):
            raise TypeError(f"videos: expected paths, got a {type(v).__name__} ({v!r:.40})")
    # Bytes paths (os.listdir(b".")) as the file system decodes them.
    videos = [os.fsdecode(os.fspath(v)) for v in videos]
    if not videos:
        raise ConfigError("no videos given")
    whole = _check_whole_numbers(threads=threads, iris_views=iris_views)
    threads, iris_views = whole["threads"], whole["iris_views"]
    _require_pandas(pandas)
    for v in videos:
        _require(v, VideoError, "cannot open video: no such file")
    results = _native.extract(
        videos,
        out=_opt_path(out),
        models=_opt_path(models),
        threads=threads,
        blink_ratio=blink_ratio,
        max_seconds=max_seconds,
        mesh_every=mesh_every,
        iris_views=iris_views,
        device=device,
        landmarks=landmarks,
        progress=_resolve_progress(progress),
    )
    tables = []
    for video, r in zip(videos, results):
        # As the command prints them: the file's rows are what it could
        # read, and the user should know when that is not all of it.
        for w in r["warnings"]:
            warnings.warn(f"{video}: {w}", EyereplayWarning, stacklevel=3)
        # The command says so on stderr; a script should hear it too.
        if device == "cuda" and not r["on_cuda"]:
            warnings.warn(
                f"{video}: CUDA not used (the ONNX Runtime library has no CUDA provider, "
                "or it did not start; EYEREPLAY_ORT_LIB names an onnxruntime-gpu build's); "
                "the networks ran on the CPU",
                EyereplayWarning,
                stacklevel=3,
            )
        t = parse_csv(r["csv"], video)
        tables.append(to_pandas(t) if pandas else t)
    return tables


EXTRACT_COLUMNS: Tuple[str, ...] = (
    "frame", "time_s", "valid", "nx", "ny", "blink", "face", "face_score", "aperture",
    "nx_left", "ny_left", "nx_right", "ny_right", "aperture_left", "aperture_right",
    "iris_left_x_px", "iris_left_y_px", "iris_right_x_px", "iris_right_y_px",
    "left_eye_left_corner_x_px", "left_eye_left_corner_y_px",
    "left_eye_right_corner_x_px", "left_eye_right_corner_y_px",
    "right_eye_left_corner_x_px", "right_eye_left_corner_y_px",
    "right_eye_right_corner_x_px", "right_eye_right_corner_y_px",
    "nx_head",
)


def prepare(
    config: _Config,
    out: Optional[PathLike],
    *,
    cache: Optional[PathLike] = None,
    dry_run: bool = False,
    base_dir: Optional[PathLike] = None,
    progress: Any = True,
) -> Dict[str, Any]:
    """Stages 1-5 (``eyereplay prepare``): extract video sources (cached),
    calibrate, filter blinks, resample, normalize and slice, then write the
    session CSVs, pools, ``labels.csv`` and ``metadata.json`` into ``out``.

    ``config`` is a TOML path or a dict of the same tables (relative source
    paths in a dict resolve against ``base_dir``, default the current
    folder). With ``dry_run`` (or ``out=None``) nothing is written. Returns a
    summary: calibration, per-source rate/samples/filled/alpha/frames,
    per-class sessions/pool/stride/reuse ratio/speed scale, warnings.
    """
    path, toml, label, base = _config_args(config, base_dir)
    return _native.prepare(
        path,
        toml,
        label,
        base,
        _opt_path(out),
        cache=_opt_path(cache),
        dry_run=dry_run,
        progress=_resolve_progress(progress),
    )


def generate(
    config: _Config,
    out: PathLike,
    *,
    shard: Union[str, Tuple[int, int], None] = None,
    shards: Optional[int] = None,
    cache: Optional[PathLike] = None,
    evaluate: bool = True,
    base_dir: Optional[PathLike] = None,
    progress: Any = True,
) -> Dict[str, Any]:
    """The whole job (``eyereplay generate``): validates every input first
    (sources, render settings, models, ffmpeg, disk space), then extracts,
    prepares, renders each session to MP4 and, without a shard, finishes
    and evaluates the dataset. Rerun after an interruption: finished
    sessions are verified and skipped.

    ``config=None`` uses the bundled default sample, ``examples/default.toml``
    of an eyereplay checkout above the current folder (its sources come with
    the checkout; from the package alone, give a config). ``shard`` is
    ``"K/N"`` or ``(K, N)``, K counted from 0 (``(0, 4)`` to ``(3, 4)``);
    ``shards=N`` with the shard index in ``$EYEREPLAY_SHARD_INDEX`` or a
    job array's own variable, as ``--shards`` reads it. Finish a sharded
    dataset with :func:`merge`.

    Returns a dict: ``out`` (the folder, a ``Path``), ``rendered`` and
    ``skipped`` (sessions; skipped ones were already complete), ``frames``
    (rendered), ``clamped_points`` (trajectory points off the canvas,
    clamped to its edge; also an :class:`EyereplayWarning`), ``report``
    (the report's ``index.html`` as a ``str``, ``None`` without
    evaluation), ``checks`` (the report's summary: ``total``, ``passing``,
    ``failing`` as one line each, ``line`` as ``eyereplay generate`` prints
    it; ``None`` without evaluation) and ``stage_s`` (seconds per stage).
    """
    if isinstance(shard, tuple):
        if len(shard) != 2:
            raise ConfigError(f"shard {shard!r}: expected (K, N), K counted from 0")
        shard = f"{shard[0]}/{shard[1]}"
    if shards is not None:
        shards = _check_whole_numbers(shards=shards)["shards"]
    path, toml, label, base = _config_args(config, base_dir)
    result = _native.generate(
        path,
        toml,
        label,
        base,
        os.fspath(out),
        shard=shard,
        shards=shards,
        cache=_opt_path(cache),
        evaluate=evaluate,
        progress=_resolve_progress(progress),
    )
    result["out"] = Path(result["out"])
    # As the command says it on stderr.
    if result["clamped_points"] > 0:
        warnings.warn(
            f"{result['clamped_points']} trajectory points were off the canvas and clamped",
            EyereplayWarning,
            stacklevel=2,
        )
    return result


def train(
    datasets: Union[PathLike, Sequence[PathLike]],
    out: PathLike,
    *,
    window_s: float = 10.0,
    input: str = "extracted",
    classifier: str = "trees",
    seed: int = 1,
    alpha: float = 1.0,
    noise_copies: int = 0,
    frame_labels: bool = False,
    max_fpr: float = 0.05,
    cache: Optional[PathLike] = None,
    progress: Any = True,
) -> Dict[str, Any]:
    """Trains the reading detector on datasets made by :func:`generate`
    (``eyereplay train``) and writes the model to ``out`` (a ``.json``
    file), for :func:`detect`'s ``model``.

    Each session's video is read as :func:`extract` reads it (cached, so a
    second run does not extract again), cut into windows of ``window_s``
    seconds overlapping by half; ``input="trajectory"`` learns from the
    session CSVs instead (no videos needed), ``"drawn"`` from the drawn
    eyes' own positions. ``classifier`` is ``"trees"`` (100 bagged trees,
    the default) or ``"logistic"`` (``alpha`` its L2 weight);
    ``noise_copies`` adds that many noisy copies of each session (at most
    100); ``frame_labels`` labels windows by the sessions' per-frame
    ``reading`` column (interviews); the threshold is chosen so that at
    most ``max_fpr`` of held-out not-reading windows are called reading.
    Same datasets and seed give the same model file, byte for byte.

    Returns a dict: ``model`` (the file written, a ``Path``), ``kind``,
    ``window_s``, ``threshold`` (the P(reading) above which a window is
    called reading), ``features`` and ``training`` (window counts, and on
    held-out sessions ``validation_auroc``, ``validation_fpr``,
    ``validation_tpr``, ``validation_ece``). A model its own figures
    advise against (too few windows, AUROC near chance) is written, with
    an :class:`EyereplayWarning`.

    Raises :class:`ConfigError` for a bad option, :class:`DatasetError`
    for a folder that is not a dataset or a session that cannot be read.
    """
    if isinstance(datasets, (str, os.PathLike)):
        datasets = [datasets]
    datasets = [os.fspath(d) for d in datasets]
    if not datasets:
        raise ConfigError("datasets: no dataset folders given")
    for d in datasets:
        _require(d, DatasetError, "no such dataset folder")
    out_path = Path(out)
    if out_path.suffix.lower() != ".json" or out_path.is_dir():
        raise ConfigError(f"out: {os.fspath(out)}: the model is written to a file ending in .json")
    whole = _check_whole_numbers(seed=seed, noise_copies=noise_copies)
    for name, value in (("window_s", window_s), ("alpha", alpha), ("max_fpr", max_fpr)):
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
            raise ConfigError(f"{name} {value!r}: expected a number")
    # The model is written last: a folder it cannot go to is found first.
    out_path.parent.mkdir(parents=True, exist_ok=True)
    r = _native.train(
        datasets,
        os.fspath(out_path),
        window_s=float(window_s),
        input=input,
        classifier=classifier,
        seed=whole["seed"],
        alpha=float(alpha),
        noise_copies=whole["noise_copies"],
        frame_labels=bool(frame_labels),
        max_fpr=float(max_fpr),
        cache=_opt_path(cache),
        progress=_resolve_progress(progress),
    )
    for w in r["warnings"]:
        warnings.warn(w, EyereplayWarning, stacklevel=2)
    model = json.loads(r["model_json"])
    return {
        "model": out_path,
        **{k: model[k] for k in ("kind", "window_s", "threshold", "features", "training")},
    }


def merge(dataset_dir: PathLike, *, evaluate: bool = True, progress: Any = True) -> Optional[Path]:
    """Finishes a dataset rendered in shards (``eyereplay merge``): checks
    that every session is there, writes the render metadata and (with
    ``evaluate``) the report; returns the report's path. ``progress`` as
    for :func:`evaluate`."""
    _require(dataset_dir, DatasetError, "no such dataset folder")
    html = _native.merge(os.fspath(dataset_dir), evaluate=evaluate,
                         progress=_resolve_progress(progress))
    return None if html is None else Path(html)


def evaluate(
    dataset_dir: PathLike,
    *,
    visual: bool = True,
    visual_session: Optional[str] = None,
    video: Optional[PathLike] = None,
    trajectory: Optional[PathLike] = None,
    visual_seconds: float = 120.0,
    models: Optional[PathLike] = None,
    progress: Any = True,
) -> Dict[str, Any]:
    """Measures a dataset's fidelity (``eyereplay evaluate``) and writes
    ``report/index.html`` and ``report/metrics.json``; returns the metrics
    as a dict (the same document as metrics.json, so it stays one
    ``json.dump`` can write), with the report's path as a ``str`` under the
    key ``"report_html"`` and its summary under ``"checks"`` (``total``,
    ``passing``, ``failing``, ``line``: as :func:`generate` returns it).

    ``visual=False`` skips the visual-fidelity section; ``visual_session``
    picks the session whose video is read back; ``video`` with
    ``trajectory`` judges any rendered video (another simulator's, say).
    ``progress`` shows the read-backs of the videos (seconds to minutes):
    ``True`` a bar, ``False`` none, or an object with the methods of
    :class:`ProgressBar`, as for :func:`generate`.
    """
    _require(dataset_dir, DatasetError, "no such dataset folder")
    r = _native.evaluate(
        os.fspath(dataset_dir),
        visual=visual,
        visual_session=visual_session,
        video=_opt_path(video),
        trajectory=_opt_path(trajectory),
        visual_seconds=visual_seconds,
        models=_opt_path(models),
        progress=_resolve_progress(progress),
    )
    metrics = json.loads(r["metrics_json"])
    metrics["report_html"] = r["html"]
    metrics["checks"] = r["checks"]
    return metrics


def check_models(dir: Optional[PathLike] = None) -> List[str]:
    """Verifies the models folder (sha256, one inference per model):
    ``dir``, else :func:`default_models_dir` (the models shipped in this
    package, unless ``$EYEREPLAY_MODELS`` names another folder; a checkout
    makes its own with ``scripts/setup.sh``)."""
    return _native.check_models(_opt_path(dir))


def default_models_dir() -> Path:
    """Where models are looked for: ``$EYEREPLAY_MODELS``, else the ones
    shipped inside this package, else the ``.cache/models`` of a checkout
    above the current folder."""
    return Path(_native.default_models_dir())
