#!/usr/bin/env python3
"""Compares two dataset folders file by file, as the byte-identity checks in
the closing notes were made:

    python3 scripts/dev/compare_datasets.py OLD_DIR NEW_DIR

Prints, for every CSV, JSON, MP4 and HTML file in either folder, whether it
is byte-identical (sha256); for differing CSVs with x,y columns the largest
|dx| and |dy| (px); for differing JSON files the differing lines. Exit status
1 when anything differs. Standard library only.
"""
import csv
import difflib
import hashlib
import pathlib
import sys

KINDS = {".csv", ".json", ".mp4", ".html"}


def files(root):
    return {p.relative_to(root): p for p in root.rglob("*") if p.is_file() and p.suffix in KINDS}


def sha(p):
    return hashlib.sha256(p.read_bytes()).hexdigest()


def xy_delta(a, b):
    with open(a, newline="") as fa, open(b, newline="") as fb:
        ra, rb = list(csv.DictReader(fa)), list(csv.DictReader(fb))
    if not ra or "x" not in ra[0] or "y" not in ra[0] or len(ra) != len(rb):
        return None
    dx = max(abs(float(p["x"]) - float(q["x"])) for p, q in zip(ra, rb))
    dy = max(abs(float(p["y"]) - float(q["y"])) for p, q in zip(ra, rb))
    return dx, dy


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    old, new = (pathlib.Path(a) for a in sys.argv[1:])
    fo, fn = files(old), files(new)
    same = differ = 0
    for rel in sorted(set(fo) | set(fn)):
        if rel not in fo or rel not in fn:
            print(f"only in {'new' if rel in fn else 'old'}: {rel}")
            differ += 1
            continue
        if sha(fo[rel]) == sha(fn[rel]):
            same += 1
            continue
        differ += 1
        line = f"differs: {rel}"
        if rel.suffix == ".csv":
            d = xy_delta(fo[rel], fn[rel])
            if d:
                line += f"  max |dx| {d[0]:.3f} px, max |dy| {d[1]:.3f} px"
        print(line)
        if rel.suffix == ".json":
            a = fo[rel].read_text().splitlines()
            b = fn[rel].read_text().splitlines()
            for d in difflib.unified_diff(a, b, lineterm="", n=0):
                if not d.startswith(("---", "+++", "@@")):
                    print("   ", d)
    print(f"{same} identical, {differ} different")
    sys.exit(1 if differ else 0)


if __name__ == "__main__":
    main()
