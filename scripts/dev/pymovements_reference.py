"""Reference events from pymovements for eyereplay-eval's I-VT events.

eyereplay's evaluation (the paper's section 5.1) finds fixations as maximal
runs of frame-to-frame steps slower than 5 px/frame and saccades as runs
faster than 15 px/frame. pymovements finds the same runs when it is given
each step's velocity (px/s) at the step's first frame:

* fixations: ``pymovements.events.ivt`` with ``velocity_threshold`` 5 x fps
  (a sample is a fixation candidate when its velocity's norm is below it);
* saccades: ``pymovements.events.microsaccades`` with a fixed
  ``threshold`` of (15 x fps, 15 x fps) and ``threshold_factor`` 1 (a
  candidate when (vx / t)^2 + (vy / t)^2 > 1, so when the norm exceeds t);

both with ``minimum_duration`` 0, since the paper keeps every run. A run of
steps k0..k1 moves the eye from frame k0 to frame k1 + 1, so eyereplay's
event spans frames k0..k1 + 1: its onset is pymovements' and its offset one
sample later. Over those frames pymovements' own event measures give the
values eyereplay reports: ``dispersion`` ((max x - min x) + (max y - min y))
of a fixation, and ``peak_velocity`` of a saccade (over the steps k0..k1;
the step after a saccade is slower by definition).

Writes a JSON file with the input trajectories (px on the 1280x720 canvas,
25 fps) and pymovements' events and measures. Run through
scripts/dev/pymovements_reference.sh (pinned pymovements in a venv), which
takes the trajectories from a dataset made by `eyereplay generate`.
"""

import csv
import json
import sys

import numpy as np
import polars as pl
import pymovements as pm
from pymovements.measure.events.processing import EventSamplesProcessor

FPS = 25.0
FIXATION_BELOW_PX_PER_FRAME = 5.0
SACCADE_ABOVE_PX_PER_FRAME = 15.0


def read_session(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    # The CSV's decimals as written, so Rust and Python read the same numbers.
    return [r["x"] for r in rows], [r["y"] for r in rows]


def measure(events, frames, position, velocity, name):
    """pymovements' event measure `name` over each event's frames."""
    if not events:
        return []
    samples = pl.DataFrame(
        {
            "time": np.arange(len(position), dtype=np.int64),
            "position": position.tolist(),
            "velocity": velocity.tolist(),
        }
    )
    table = pl.DataFrame(
        {
            "name": ["event"] * len(events),
            "onset": [e[0] for e in events],
            "offset": [e[1] + frames for e in events],
        }
    )
    out = EventSamplesProcessor([name]).process(table, samples)
    return out[name].to_list()


def segment(name, xs, ys):
    position = np.column_stack([np.array(xs, float), np.array(ys, float)])
    steps = (position[1:] - position[:-1]) * FPS  # px/s, step k at frame k
    timesteps = np.arange(len(steps), dtype=np.int64)
    fix = pm.events.ivt(
        velocities=steps,
        timesteps=timesteps,
        minimum_duration=0,
        velocity_threshold=FIXATION_BELOW_PX_PER_FRAME * FPS,
    ).frame
    t = SACCADE_ABOVE_PX_PER_FRAME * FPS
    sac = pm.events.microsaccades(
        velocities=steps,
        timesteps=timesteps,
        minimum_duration=0,
        threshold=(t, t),
        threshold_factor=1.0,
    ).frame
    runs = lambda frame: list(zip(frame["onset"].to_list(), frame["offset"].to_list()))
    fixations, saccades = runs(fix), runs(sac)
    # A velocity per frame for the measures: the last frame starts no step.
    velocity = np.vstack([steps, [[0.0, 0.0]]])
    dispersion = measure(fixations, 1, position, velocity, "dispersion")
    peak = measure(saccades, 0, position, velocity, "peak_velocity")
    return {
        "name": name,
        "x": [float(v) for v in xs],
        "y": [float(v) for v in ys],
        "fixations": [
            {"onset_step": a, "offset_step": b, "dispersion_px": d}
            for (a, b), d in zip(fixations, dispersion)
        ],
        "saccades": [
            {"onset_step": a, "offset_step": b, "peak_velocity_px_per_s": p}
            for (a, b), p in zip(saccades, peak)
        ],
    }


def main():
    out, sessions = sys.argv[1], sys.argv[2:]
    segments = []
    for path in sessions:
        xs, ys = read_session(path)
        name = "/".join(path.split("/")[-2:])
        segments.append(segment(name, xs, ys))
    doc = {
        "made_by": "scripts/dev/pymovements_reference.sh",
        "pymovements": pm.__version__,
        "fps": FPS,
        "fixation_below_px_per_frame": FIXATION_BELOW_PX_PER_FRAME,
        "saccade_above_px_per_frame": SACCADE_ABOVE_PX_PER_FRAME,
        "segments": segments,
    }
    with open(out, "w") as f:
        json.dump(doc, f, indent=None, separators=(",", ":"))
        f.write("\n")
    for s in segments:
        print(f"{s['name']}: {len(s['x'])} frames, {len(s['fixations'])} fixations, "
              f"{len(s['saccades'])} saccades")


main()
