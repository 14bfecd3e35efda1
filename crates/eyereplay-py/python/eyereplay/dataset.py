"""A dataset folder written by :func:`eyereplay.generate` (or ``prepare``),
read as Python objects: sessions with their label, class, trajectory
(numpy), ground truth and video, and a PyTorch view of them."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Dict, Iterator, List, Optional, Sequence, Tuple, Union

import numpy as np

from . import _native
from ._native import DatasetError, VideoError
from ._errors import require
from ._table import read_csv


@dataclass(frozen=True)
class Session:
    """One session: ``label`` is 1 for reading and 0 for conversation, as
    in ``labels.csv``. File contents are read when first asked for."""

    file: str
    label: int
    class_name: str
    sources: Tuple[str, ...]
    csv_path: Path
    video_path: Path
    truth_path: Path
    identity_path: Path
    _cache: Dict[str, Any] = field(default_factory=dict, repr=False, compare=False)

    @property
    def trajectory(self) -> np.ndarray:
        """``frame, x, y[, blink]`` in canvas pixels (structured array)."""
        if "trajectory" not in self._cache:
            self._cache["trajectory"] = read_csv(self.csv_path)
        return self._cache["trajectory"]

    @property
    def xy(self) -> np.ndarray:
        """The trajectory as a float64 ``(frames, 2)`` array of canvas px."""
        t = self.trajectory
        return np.stack([t["x"], t["y"]], axis=1)

    @property
    def video(self) -> Optional[Path]:
        """The rendered MP4, or None when this session is not rendered."""
        return self.video_path if self.video_path.is_file() else None

    @property
    def truth(self) -> Optional[np.ndarray]:
        """Per-frame ground truth written with the video (eye angles, iris
        and pupil positions, lid state), or None when not rendered."""
        if not self.truth_path.is_file():
            return None
        if "truth" not in self._cache:
            self._cache["truth"] = read_csv(self.truth_path)
        return self._cache["truth"]

    @property
    def identity(self) -> Optional[Dict[str, Any]]:
        """The rendered eye's identity (iris colour, eye geometry, ...)."""
        if not self.identity_path.is_file():
            return None
        with open(self.identity_path, encoding="utf-8") as f:
            return json.load(f)

    def frames(self, start: int = 0, count: Optional[int] = None) -> np.ndarray:
        """Decoded RGB frames ``[start, start + count)`` of the video as a
        ``uint8`` array of shape ``(count, height, width, 3)``, read with
        the ffmpeg program (exact frame seek); ``count`` defaults to the
        rest of the video, and one that runs past its end is a
        :class:`VideoError`."""
        if self.video is None:
            raise VideoError(f"{self.video_path}: not rendered (run eyereplay.generate)")
        return decode_frames(self.video_path, start, count)


class Dataset(Sequence[Session]):
    """The sessions of a dataset folder, in ``labels.csv`` order, with its
    ``metadata`` (the metadata.json document as a dict)."""

    def __init__(self, root: Path, metadata: Dict[str, Any], sessions: List[Session]):
        self.root = root
        self.metadata = metadata
        self.sessions = sessions

    def __len__(self) -> int:
        return len(self.sessions)

    def __getitem__(self, i):  # type: ignore[override]
        # A slice is a Dataset of those sessions (its metadata and
        # as_torch kept), as a list's slice is a list.
        if isinstance(i, slice):
            return Dataset(self.root, self.metadata, self.sessions[i])
        return self.sessions[i]

    def __iter__(self) -> Iterator[Session]:
        return iter(self.sessions)

    def __repr__(self) -> str:
        counts = {c: sum(s.class_name == c for s in self.sessions) for c in self.classes}
        return f"Dataset({str(self.root)!r}, sessions={counts})"

    @property
    def classes(self) -> List[str]:
        seen: List[str] = []
        for s in self.sessions:
            if s.class_name not in seen:
                seen.append(s.class_name)
        return seen

    @property
    def labels(self) -> np.ndarray:
        return np.array([s.label for s in self.sessions], dtype=np.int64)

    @property
    def fps(self) -> float:
        return float(self.metadata["fps"])

    @property
    def canvas_px(self) -> Tuple[int, int]:
        c = self.metadata["canvas"]
        return int(c["width_px"]), int(c["height_px"])

    def as_torch(
        self,
        window: Optional[int] = None,
        stride: Optional[int] = None,
        video: bool = False,
        normalize: bool = True,
        transform=None,
    ):
        """A ``torch.utils.data.Dataset`` of ``(x, label)`` pairs (torch is
        imported here, not when eyereplay is).

        Trajectories (default): ``x`` is a float32 tensor ``(window, 2)`` of
        canvas x, y (divided by the canvas size with ``normalize``); each
        session gives windows starting every ``stride`` frames (default:
        non-overlapping), or one whole session with ``window=None``.

        ``video=True``: ``x`` is a uint8 tensor ``(window, H, W, 3)`` of RGB
        frames, decoded on demand from the session's MP4 (``window``
        defaults to 2 s). ``transform`` is applied to ``x``.
        """
        try:
            import torch
            from torch.utils.data import Dataset as TorchDataset
        except ImportError:
            raise ImportError("as_torch() needs PyTorch: pip install torch") from None
        sessions = [s for s in self.sessions if not video or s.video is not None]
        if video and not sessions:
            raise DatasetError(f"{self.root}: no rendered sessions (video=True needs MP4s)")
        frames = int(self.metadata["session_frames"])
        if window is None:
            window = max(1, int(round(2 * self.fps))) if video else frames
        if window < 1 or window > frames:
            raise ValueError(f"window {window}: must be 1..{frames} (the session length)")
        # None is the default (windows side by side); 0 is not it.
        stride = window if stride is None else stride
        if stride < 1:
            raise ValueError(f"stride {stride}: must be at least 1")
        starts = list(range(0, frames - window + 1, stride))
        index = [(si, st) for si in range(len(sessions)) for st in starts]
        scale = np.array(self.canvas_px, dtype=np.float64) if normalize else np.ones(2)

        class _Windows(TorchDataset):
            def __len__(self) -> int:
                return len(index)

            def __getitem__(self, i: int):
                si, start = index[i]
                s = sessions[si]
                if video:
                    x = torch.from_numpy(s.frames(start, window))
                else:
                    xy = (s.xy[start : start + window] / scale).astype(np.float32)
                    x = torch.from_numpy(xy)
                if transform is not None:
                    x = transform(x)
                return x, torch.tensor(s.label, dtype=torch.int64)

        return _Windows()


def load_dataset(dataset_dir: Union[str, "os.PathLike[str]"]) -> Dataset:
    """Reads ``labels.csv`` and ``metadata.json`` (checking the format
    version, as every eyereplay reader does); trajectories, truth and
    frames are read when used."""
    if not isinstance(dataset_dir, (str, os.PathLike)):
        raise TypeError(f"dataset_dir: expected a folder path, got a {type(dataset_dir).__name__}")
    root = Path(dataset_dir)
    require(root, DatasetError, "no such dataset folder")
    meta_text, rows = _native.dataset_index(os.fspath(root))
    sessions = [
        Session(
            file=r["file"],
            label=int(r["label"]),
            class_name=r["class"],
            sources=tuple(r["sources"]),
            csv_path=Path(r["csv"]),
            video_path=Path(r["mp4"]),
            truth_path=Path(r["truth"]),
            identity_path=Path(r["identity"]),
        )
        for r in rows
    ]
    return Dataset(root, json.loads(meta_text), sessions)


def decode_frames(video: Path, start: int = 0, count: Optional[int] = None) -> np.ndarray:
    """RGB frames of any video via the ffmpeg program: ``uint8 (n, h, w, 3)``.
    ``start`` and ``count`` are whole numbers, 0 or more; a ``start`` at or
    past the last frame, or a ``count`` that runs past it, is a
    :class:`VideoError` (a shorter array would pass for a short read)."""
    for name, value in (("start", start), ("count", count)):
        if value is None and name == "count":
            continue
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 0:
            raise ValueError(f"{name} {value!r}: expected a whole number, 0 or more")
    ffmpeg = shutil.which("ffmpeg")
    if ffmpeg is None:
        raise VideoError("ffmpeg not found on PATH (Debian: apt-get install ffmpeg)")
    w, h, fps = _probe(video)
    cmd = [ffmpeg, "-v", "error", "-nostdin"]
    if start > 0:
        # Input seeking decodes from the key frame before and drops frames up
        # to the exact time, so frame `start` is the first one out.
        cmd += ["-ss", f"{(start - 0.5) / fps:.6f}"]
    cmd += ["-i", os.fspath(video)]
    if count is not None:
        cmd += ["-frames:v", str(int(count))]
    cmd += ["-f", "rawvideo", "-pix_fmt", "rgb24", "pipe:1"]
    r = subprocess.run(cmd, capture_output=True)
    if r.returncode != 0:
        msg = r.stderr.decode("utf-8", "replace").strip().splitlines()
        raise VideoError(f"{video}: ffmpeg failed: {msg[-1] if msg else r.returncode}")
    n = len(r.stdout) // (w * h * 3)
    if n == 0 and start > 0 and count != 0:
        raise VideoError(f"{video}: frame {start} is past its last frame")
    # Fewer frames than asked for would change a batch's shape downstream.
    if count is not None and n < count:
        raise VideoError(
            f"{video}: {count} frames asked from frame {start}, but the video ends "
            f"{n} frames later (at frame {start + n})"
        )
    return np.frombuffer(r.stdout, dtype=np.uint8)[: n * w * h * 3].reshape(n, h, w, 3)


def _probe(video: Path) -> Tuple[int, int, float]:
    ffprobe = shutil.which("ffprobe")
    if ffprobe is None:
        raise VideoError("ffprobe not found on PATH (Debian: apt-get install ffmpeg)")
    r = subprocess.run(
        [ffprobe, "-v", "error", "-select_streams", "v:0", "-show_entries",
         "stream=width,height,avg_frame_rate", "-of", "json", os.fspath(video)],
        capture_output=True,
    )
    try:
        st = json.loads(r.stdout)["streams"][0]
        num, den = st["avg_frame_rate"].split("/")
        return int(st["width"]), int(st["height"]), float(num) / float(den)
    except (KeyError, IndexError, ValueError, ZeroDivisionError):
        raise VideoError(f"{video}: not a readable video") from None
