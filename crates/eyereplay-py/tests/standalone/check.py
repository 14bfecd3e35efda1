"""The wheel on its own (scripts/python-test.sh runs this from an empty
folder, in a fresh venv holding only numpy and the wheel, with HOME a fresh
folder and no EYEREPLAY_* variable): extract a video and frames in memory,
detect with the detector shipped inside the package, and generate a tiny
dataset of generated people, as close-up eyes and as whole faces. Prints the import and first-extract times and
fails on any difference from what a checkout gives."""

import json
import os
import sys
import time
from pathlib import Path

t0 = time.perf_counter()
import eyereplay  # noqa: E402

import_s = time.perf_counter() - t0

import numpy as np  # noqa: E402

here = Path.cwd()
video, raw, want_csv = Path(sys.argv[1]), Path(sys.argv[2]), Path(sys.argv[3])
width, height = int(sys.argv[4]), int(sys.argv[5])

# Nothing of the checkout is reachable: the package's own files serve.
assert "EYEREPLAY_MODELS" not in os.environ and "EYEREPLAY_CACHE" not in os.environ
models = eyereplay.default_models_dir()
assert models == eyereplay.PACKAGE_MODELS, models
assert str(eyereplay.cache_dir()).startswith(os.environ["HOME"]), eyereplay.cache_dir()

t0 = time.perf_counter()
table = eyereplay.extract(video, progress=False, out=here / "clip.csv")
first_extract_s = time.perf_counter() - t0
# Byte-identical to the command line's CSV of the same clip.
assert (here / "clip.csv").read_bytes() == want_csv.read_bytes(), "extract CSV differs"
# franck.mp4's first 12 s: a face in every frame, open eyes in 78 % of them.
assert len(table) > 0 and table["face"].sum() > 0.95 * len(table)
assert table["valid"].sum() > 0.6 * len(table)

# Frames in memory: the same clip decoded to RGB by ffmpeg.
frames = np.fromfile(raw, dtype=np.uint8).reshape(-1, height, width, 3)
from_frames = eyereplay.extract(frames, fps=25.0, progress=False)
assert len(from_frames) == len(frames)
both = (table["valid"][: len(frames)] == 1) & (from_frames["valid"] == 1)
assert both.sum() > 0.6 * len(frames), both.sum()
dx = np.abs(table["nx"][: len(frames)][both] - from_frames["nx"][both])
assert np.median(dx) < 0.01, np.median(dx)

# The detector shipped in the package, on the video and on the frames.
d = eyereplay.detect(video, progress=False)
assert d["verdict"] in ("reading", "not reading"), d["verdict"]
assert len(d["windows"]) >= 1 and 0.0 <= d["reading_probability"] <= 1.0
d2 = eyereplay.detect(frames, fps=25.0, progress=False)
assert d2["input"]["path"] == "<frames>"

# A tiny dataset from generated people only, from this empty folder.
cfg = {
    "session_frames": 50,
    "seed": 3,
    "render": {"width": 160, "height": 90, "jobs": 1},
    "classes": {
        "reading": {"sessions": 1, "generators": [{"model": "reading"}]},
        "conversation": {"sessions": 1, "generators": [{"model": "conversation"}]},
    },
}
g = eyereplay.generate(cfg, here / "data", progress=False)
assert (here / "data" / "reading" / "reading_0000.mp4").is_file()
assert (here / "data" / "report" / "index.html").is_file()
# Whole faces too, from the photos and mesh shipped in the package.
faces = dict(cfg, render={"backend": "face", "width": 320, "height": 240, "jobs": 1})
gf = eyereplay.generate(faces, here / "faces", evaluate=False, progress=False)
assert gf["rendered"] == 2, gf
assert (here / "faces" / "reading" / "reading_0000_head.csv").is_file()
# Caches went to the user's cache folder, never to this folder.
assert not (here / ".cache").exists()
print(json.dumps({
    "import_s": round(import_s, 3),
    "first_extract_s": round(first_extract_s, 3),
    "clip_frames": len(table),
    "verdict": d["verdict"],
    "frames_verdict": d2["verdict"],
    "rendered": g.get("rendered"),
    "faces_rendered": gf.get("rendered"),
}))
