"""Ctrl-C in a terminal, or a notebook's interrupt, stops long work: the
call raises KeyboardInterrupt part-way, leaves nothing half-written, and
the interpreter goes on. Python runs its signal handler only on the main
thread while it runs Python code; the package's calls release the GIL for
minutes, so each watches for signals itself (`interruptible` in
src/lib.rs). Each case runs in a child interpreter that is sent SIGINT
once the work has started."""

import json
import signal
import subprocess
import sys
from pathlib import Path

from conftest import DATA, small_config

CHILD = r"""
import json, signal, sys, eyereplay
# A process started in the background may inherit SIGINT ignored; an
# interactive interpreter has Python's own handler, as here.
signal.signal(signal.SIGINT, signal.default_int_handler)
job = json.loads(sys.argv[1])

class Progress:
    "Says when the work is under way, on the line the parent waits for."
    def __init__(self):
        self.frames = 0
        self.stage = None
        self.said = False
    def begin(self, stage, total):
        self.stage = stage
    def advance(self, n):
        if self.stage != job["stage"]:
            return
        self.frames += n
        if not self.said and self.frames >= job["started_after"]:
            self.said = True
            print("started", flush=True)
    def __getattr__(self, name):
        return lambda *args: None

p = Progress()
try:
    if job["kind"] == "extract":
        eyereplay.extract(job["video"], progress=p)
    else:
        eyereplay.generate(job["config"], job["out"], cache=job["cache"], progress=p)
    print("finished", p.frames, flush=True)
except KeyboardInterrupt:
    print("interrupted", p.frames, flush=True)
# The interpreter is still usable after the interrupt.
print("alive", sum(range(10)), flush=True)
"""


def interrupted(job: dict) -> list:
    child = subprocess.Popen(
        [sys.executable, "-c", CHILD, json.dumps(job)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    first = child.stdout.readline().strip()
    assert first == "started", (first, child.stderr.read())
    child.send_signal(signal.SIGINT)
    rest, err = child.communicate(timeout=300)
    assert child.returncode == 0, err
    return rest.split()


def test_an_extraction_stops_part_way():
    # franck.mp4 has 4,800 frames; the signal comes after the first 48.
    words = interrupted(
        {
            "kind": "extract",
            "video": str(DATA / "franck.mp4"),
            "stage": "extract",
            "started_after": 48,
        }
    )
    assert words[0] == "interrupted", words
    assert int(words[1]) < 4800
    assert words[2:] == ["alive", "45"]


def test_a_generate_stops_part_way_and_leaves_no_unfinished_file(tmp_path, cache_dir):
    cfg = small_config()
    # 4 sessions of 20 s: the signal comes once the first is drawn.
    cfg["session_frames"] = 500
    out = tmp_path / "d"
    words = interrupted(
        {
            "kind": "generate",
            "config": cfg,
            "out": str(out),
            "cache": cache_dir,
            "stage": "render",
            "started_after": 500,
        }
    )
    assert words[0] == "interrupted", words
    assert words[2:] == ["alive", "45"]
    videos = sorted(out.rglob("*.mp4"))
    assert len(videos) < 4, videos
    # Staged files, first passes, videos being encoded, the render lock.
    hidden = [p.relative_to(out).as_posix() for p in out.rglob(".*")]
    assert hidden == [], hidden
