#!/usr/bin/env python3
"""How well the extractor's x follows the drawn eye, against the model's own
eye corners (`nx`) and against corners anchored to the head (`nx_head`):

    eyereplay extract --landmarks cascade DATASET/*/*.mp4 --out EXTRACTED
    python3 scripts/dev/anchor_vs_truth.py DATASET EXTRACTED
    python3 scripts/dev/anchor_vs_truth.py --no-truth EXTRACT.csv ...

DATASET is a generated dataset (`eyereplay generate`); EXTRACTED holds
`eyereplay extract`'s `<video stem>.csv` of its videos (`--landmarks
cascade`, as the detector reads them). For each video with a `_truth.csv`
it prints, for both columns: the gain (slope of the extracted x on the drawn
eyes' mean nx), r, and the frame-to-frame noise (the sd of the extracted
step, divided by the gain, minus the drawn step, over the sd of the drawn
step: 0 is perfect, 1 is noise as large as the eye's own movement). Then
the medians. Frames valid in the extraction and open in the drawing only.

With --no-truth (real video, no drawn eyes to compare with): for each
extraction CSV, the 5-95 % range of nx_head over that of nx, and r
between them, whole and in their fast part (minus a 1-s running mean).
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


def running_mean_residual(v, half=12):
    out = []
    for i in range(len(v)):
        w = v[max(0, i - half) : i + half + 1]
        out.append(v[i] - sum(w) / len(w))
    return out


def no_truth(paths):
    print(f"{'extraction':32s} {'frames':>6s} {'range ratio':>11s} {'r':>6s} {'r fast':>6s}")
    for path in paths:
        with open(path) as f:
            rows = [r for r in csv.DictReader(f) if r["valid"] == "1" and r.get("nx_head")]
        if len(rows) < 50:
            sys.exit(f"{path}: {len(rows)} frames with nx and nx_head, too few")
        nx = [float(r["nx"]) for r in rows]
        head = [float(r["nx_head"]) for r in rows]
        q = statistics.quantiles
        ratio = (q(head, n=20)[-1] - q(head, n=20)[0]) / (q(nx, n=20)[-1] - q(nx, n=20)[0])
        r = fit(nx, head)[1]
        r_fast = fit(running_mean_residual(nx), running_mean_residual(head))[1]
        print(f"{os.path.basename(path):32s} {len(rows):6d} {ratio:11.2f} {r:6.3f} {r_fast:6.3f}")


def main():
    if len(sys.argv) >= 3 and sys.argv[1] == "--no-truth":
        return no_truth(sys.argv[2:])
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
