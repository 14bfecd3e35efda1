"""eyereplay: real human eye movements in, labeled synthetic eye-movement
video out, from Python.

The same pipeline as the ``eyereplay`` command (it is the same Rust library
inside this package), with numpy in and out::

    import eyereplay

    iris = eyereplay.extract("interview.mp4")           # per-frame table
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
import os
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
from ._progress import EyereplayWarning, ProgressBar
from ._progress import resolve as _resolve_progress
from ._table import parse_csv, read_csv, to_pandas
from .dataset import Dataset, Session, load_dataset

__version__ = _native.version()

__all__ = [
    "extract",
    "extract_many",
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
]

PathLike = Union[str, "os.PathLike[str]"]
Config = Union[PathLike, Mapping[str, Any], None]

_DICT_LABEL = "<config dict>"


def _config_args(config: Config, base_dir: Optional[PathLike]) -> Tuple[Any, Any, str, Any]:
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
        try:
            text = json.dumps(config, default=os.fspath)
        except TypeError as e:
            raise ConfigError(f"{_DICT_LABEL}: {e}") from None
        toml = _native.json_to_toml(_DICT_LABEL, text)
        return None, toml, _DICT_LABEL, os.fspath(base_dir) if base_dir is not None else None
    if isinstance(config, (str, os.PathLike)):
        return os.fspath(config), None, "", None
    raise ConfigError(
        f"config must be a TOML path or a dict, not {type(config).__name__}"
    )


def _opt_path(p: Optional[PathLike]) -> Optional[str]:
    return None if p is None else os.fspath(p)


def extract(
    video: PathLike,
    *,
    out: Optional[PathLike] = None,
    pandas: bool = False,
    models: Optional[PathLike] = None,
    threads: int = 0,
    blink_ratio: float = 0.6,
    max_seconds: Optional[float] = None,
    mesh_every: int = 2,
    iris_views: int = 1,
    device: str = "cpu",
    landmarks: str = "cascade",
    progress: Any = True,
):
    """Stage 1: the iris position in the eye aperture, one row per decoded
    frame of ``video``.

    Returns a numpy structured array with the columns of ``eyereplay
    extract``'s CSV (``frame, time_s, valid, nx, ny, blink, face, ...``;
    see :data:`EXTRACT_COLUMNS`), or a pandas DataFrame with
    ``pandas=True``. ``nx`` runs from the image-left eye corner (0) to the
    image-right one (1), ``ny`` from the upper lid (0) to the lower (1);
    frames without a face have ``valid == 0`` and NaN positions. With
    ``out``, the CSV is also written there, byte-identical to the command's.

    ``device`` is ``"cpu"`` (the default: these small networks ran slower
    on a GPU), ``"cuda"`` (with ``EYEREPLAY_ORT_LIB`` pointing at an
    onnxruntime-gpu build's ``libonnxruntime.so``) or ``"auto"`` (CUDA when
    that library has it); ``iris_views`` reads each eye from that many
    shifted crops and averages them (``--iris-views``: more precise, about
    as many times the iris model's CPU time); ``landmarks="attention"``
    reads face, eyes and irises with MediaPipe's attention face mesh, the
    network of MediaPipe's ``refine_landmarks=True`` (``--landmarks``: the
    closest to MediaPipe's output, and about 1.5x fewer CPU-seconds than the
    default ``"cascade"``); the other options are the command's flags.
    Raises :class:`VideoError` for an unreadable video or one with no face,
    :class:`ModelError` when the models are missing (see :func:`check_models`).
    """
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


def extract_many(
    videos: Sequence[PathLike],
    *,
    out: Optional[PathLike] = None,
    pandas: bool = False,
    models: Optional[PathLike] = None,
    threads: int = 0,
    blink_ratio: float = 0.6,
    max_seconds: Optional[float] = None,
    mesh_every: int = 2,
    iris_views: int = 1,
    device: str = "cpu",
    landmarks: str = "cascade",
    progress: Any = True,
) -> list:
    """:func:`extract` on several videos at once (in parallel), one table
    each in the order given. ``out`` is a ``.csv`` file for one video or a
    folder that gets ``<video stem>.csv`` for each."""
    videos = [os.fspath(v) for v in videos]
    if not videos:
        raise ConfigError("no videos given")
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
)


def prepare(
    config: Config,
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
    config: Config,
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

    ``config=None`` uses the bundled default sample (``examples/default.toml``
    of a checkout above the current folder). ``shard`` is ``"K/N"`` or
    ``(K, N)``; finish a sharded dataset with :func:`merge`. Returns the
    sessions rendered/skipped, frames, the report path and seconds per stage.
    """
    if isinstance(shard, tuple):
        shard = f"{shard[0]}/{shard[1]}"
    path, toml, label, base = _config_args(config, base_dir)
    return _native.generate(
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


def merge(dataset_dir: PathLike, *, evaluate: bool = True) -> Optional[Path]:
    """Finishes a dataset rendered in shards (``eyereplay merge``): checks
    that every session is there, writes the render metadata and (with
    ``evaluate``) the report; returns the report's path."""
    html = _native.merge(os.fspath(dataset_dir), evaluate=evaluate)
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
) -> Dict[str, Any]:
    """Measures a dataset's fidelity (``eyereplay evaluate``) and writes
    ``report/index.html`` and ``report/metrics.json``; returns the metrics
    as a dict (the same document as metrics.json), with the report's path
    under the key ``"report_html"``.

    ``visual=False`` skips the visual-fidelity section; ``visual_session``
    picks the session whose video is read back; ``video`` with
    ``trajectory`` judges any rendered video (another simulator's, say).
    """
    r = _native.evaluate(
        os.fspath(dataset_dir),
        visual=visual,
        visual_session=visual_session,
        video=_opt_path(video),
        trajectory=_opt_path(trajectory),
        visual_seconds=visual_seconds,
        models=_opt_path(models),
    )
    metrics = json.loads(r["metrics_json"])
    metrics["report_html"] = r["html"]
    return metrics


def check_models(dir: Optional[PathLike] = None) -> List[str]:
    """Verifies the models folder (sha256, one inference per model). The
    models are fetched and converted by a checkout's ``scripts/setup.sh``
    (``scripts/models.sh DIR``), into ``$EYEREPLAY_MODELS`` or
    :func:`default_models_dir`."""
    return _native.check_models(_opt_path(dir))


def default_models_dir() -> Path:
    """Where models are looked for: ``$EYEREPLAY_MODELS``, else the
    ``.cache/models`` of a checkout above the current folder, else
    ``.cache/models`` in the current folder."""
    return Path(_native.default_models_dir())
