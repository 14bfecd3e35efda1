#!/usr/bin/env python3
"""Low end of the frame-speed distribution of each class's source pool: how
still fixations are (the "noisy vs smooth" check of docs/PIPELINE.md).

    python3 scripts/dev/pool_noise.py DATASET_DIR
"""
import csv
import math
import sys

for cls in ("reading", "conversation"):
    with open(f"{sys.argv[1]}/pool/{cls}.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    speeds = sorted(
        math.hypot(float(b["x"]) - float(a["x"]), float(b["y"]) - float(a["y"]))
        for a, b in zip(rows, rows[1:])
        if a["source"] == b["source"]  # not across two concatenated recordings
    )
    q = lambda p: speeds[int(p * len(speeds))]
    still = sum(s < 0.5 for s in speeds) / len(speeds)
    print(f"{cls:13s} speed p10 {q(0.1):.2f} p25 {q(0.25):.2f} median {q(0.5):.2f} px/frame, "
          f"{100 * still:.0f} % of frames below 0.5 px/frame")
