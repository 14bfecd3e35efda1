#!/usr/bin/env python3
"""How well the extractor's x follows the drawn eye, against the model's own
eye corners (`nx`) and against corners anchored to the head (`nx_head`):

    eyereplay extract --landmarks cascade DATASET/*/*.mp4 --out EXTRACTED
    python3 scripts/dev/anchor_vs_truth.py DATASET EXTRACTED

DATASET is a generated dataset (`eyereplay generate`); EXTRACTED holds
`eyereplay extract`'s `<video stem>.csv` of its videos (`--landmarks
cascade`, as the detector reads them). For each video with a `_truth.csv`
it prints, for both columns: the gain (slope of the extracted x on the drawn
eyes' mean nx), r, and the frame-to-frame noise (the sd of the extracted
step, divided by the gain, minus the drawn step, over the sd of the drawn
step: 0 is perfect, 1 is noise as large as the eye's own movement). Then
the medians. Frames valid in the extraction and open in the drawing only.
Standard library only.
"""
import csv
import glob
import os
import statistics
import sys

def fit(xs, ys):
    """Slope of ys on xs and Pearson's r."""
    mx, my = statistics.fmean(xs), statistics.fmean(ys)
    sxx = sum((x - mx) ** 2 for x in xs)
    syy = sum((y - my) ** 2 for y in ys)
    sxy = sum((x - mx) * (y - my) for x, y in zip(xs, ys))
    return sxy / sxx, sxy / (sxx * syy) ** 0.5


def measure(ext, truth, column):
    pairs = []
    for e, t in zip(ext, truth):
        ok = e["valid"] == "1" and t["blink"] == "0" and e.get(column, "") != ""
        truth_nx = (float(t["left_nx"]) + float(t["right_nx"])) / 2
        pairs.append((float(e[column]), truth_nx) if ok else None)
    both = [p for p in pairs if p]
    gain, r = fit([p[1] for p in both], [p[0] for p in both])
    steps = [
        (b[0] - a[0]) / gain - (b[1] - a[1])
        for a, b in zip(pairs, pairs[1:])
        if a and b
    ]
    true_steps = [b[1] - a[1] for a, b in zip(pairs, pairs[1:]) if a and b]
    return gain, r, statistics.pstdev(steps) / statistics.pstdev(true_steps)


def main():
    if len(sys.argv) != 3:
        sys.exit("usage: anchor_vs_truth.py DATASET EXTRACTED")
    dataset, extracted = sys.argv[1:]
    rows = {"nx": [], "nx_head": []}
    print(f"{'video':32s} {'column':8s} {'gain':>6s} {'r':>6s} {'noise':>6s}")
    for truth_path in sorted(glob.glob(os.path.join(dataset, "*", "*_truth.csv"))):
        video = truth_path[: -len("_truth.csv")] + ".mp4"
        ext_path = os.path.join(extracted, os.path.basename(truth_path)[: -len("_truth.csv")] + ".csv")
        if not os.path.isfile(ext_path):
            print(f"{os.path.basename(video)}: not extracted ({ext_path})", file=sys.stderr)
            continue
        with open(ext_path) as f:
            ext = list(csv.DictReader(f))
        if "nx_head" not in ext[0]:
            sys.exit(f"{ext_path}: no nx_head column (extracted by an eyereplay before it)")
        with open(truth_path) as f:
            truth = list(csv.DictReader(f))
        for column in rows:
            g, r, noise = measure(ext, truth, column)
            rows[column].append((g, r, noise))
            print(f"{os.path.basename(video):32s} {column:8s} {g:6.3f} {r:6.3f} {noise:6.3f}")
    for column, vals in rows.items():
        if vals:
            med = [statistics.median(v[k] for v in vals) for k in range(3)]
            print(f"{'median of ' + str(len(vals)):32s} {column:8s} {med[0]:6.3f} {med[1]:6.3f} {med[2]:6.3f}")


if __name__ == "__main__":
    main()
