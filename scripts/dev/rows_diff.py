#!/usr/bin/env python3
"""How far two extraction CSVs of the same video are apart:

    python3 scripts/dev/rows_diff.py BASE.csv OTHER.csv

Prints one line: in how many frames the valid flag differs, and the median,
99th percentile and largest |difference| of nx and ny over the frames valid
in both (open eyes). Used by cuda-check.sh (CUDA against the CPU) and
ab-extract.sh (one build against another). Standard library only; a file of
another length is refused in one line.
"""
import csv
import sys


def load(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def main():
    if len(sys.argv) != 3:
        sys.exit("usage: rows_diff.py BASE.csv OTHER.csv")
    base, other = sys.argv[1:]
    a, b = load(base), load(other)
    if len(a) != len(b):
        sys.exit(f"rows_diff: {other}: {len(b)} frames, but {base} has {len(a)}")
    flips = sum(x["valid"] != y["valid"] for x, y in zip(a, b))
    parts = []
    for c in ["nx", "ny"]:
        diff = sorted(abs(float(x[c]) - float(y[c])) for x, y in zip(a, b)
                      if x["valid"] == "1" and y["valid"] == "1")
        if not diff:
            parts.append(f"{c}: no frame valid in both")
            continue
        parts.append(f"{c} |d| median {diff[len(diff) // 2]:.1e}, "
                     f"p99 {diff[int(len(diff) * 0.99)]:.1e}, max {diff[-1]:.1e}")
    print(f"{other} vs {base}: valid flags differ in {flips} of {len(a)} frames; "
          "open-eye frames: " + "; ".join(parts))


if __name__ == "__main__":
    main()
