#!/usr/bin/env python3
"""Per-axis or joint blink filling: evidence from real webcam extractions.

For each `eyereplay extract` CSV given, takes the gaze samples (valid, not
blink), fences each axis at [Q1 - 3 IQR, Q3 + 3 IQR] (numpy's linear
percentiles) and, at samples where only one axis is outside its fence, asks
how far the OTHER axis lies from the straight line between its neighbouring
samples good on both axes. The baseline is the same residual for good samples
over the same spans (gap before and after). A ratio well above 1 means a
glitch on one axis drags the other along (the joint rule fits); near 1 means
the other axis is sound (the per-axis rule fits). Standard library only.

    python3 scripts/dev/blink_axes_evidence.py $EYEREPLAY_CACHE/extract/*.csv
"""
import bisect
import csv
import statistics as st
import sys


def pct(v, q):
    s = sorted(v)
    p = q / 100 * (len(s) - 1)
    lo = int(p)
    hi = min(lo + 1, len(s) - 1)
    return s[lo] + (s[hi] - s[lo]) * (p - lo)


def fence(v):
    q1, q3 = pct(v, 25), pct(v, 75)
    return q1 - 3 * (q3 - q1), q3 + 3 * (q3 - q1)


def report(path):
    rows = [r for r in csv.DictReader(open(path)) if r["valid"] == "1" and r.get("blink", "0") == "0"]
    x = [float(r["nx"]) for r in rows]
    y = [float(r["ny"]) for r in rows]
    fx, fy = fence(x), fence(y)
    ox = [not (fx[0] <= v <= fx[1]) for v in x]
    oy = [not (fy[0] <= v <= fy[1]) for v in y]
    good = [i for i in range(len(x)) if not ox[i] and not oy[i]]
    good_set = set(good)

    def residuals(v, sel):
        out, base = [], []
        for i in sel:
            k = bisect.bisect_left(good, i)
            if k == 0 or k == len(good):
                continue
            a, b = good[k - 1], good[k]
            da, db = i - a, b - i
            w = da / (da + db)
            out.append(abs(v[i] - (v[a] + w * (v[b] - v[a]))))
            for j in good[::7]:
                if j - da in good_set and j + db in good_set:
                    base.append(abs(v[j] - (v[j - da] + w * (v[j + db] - v[j - da]))))
        return out, base

    x_only = [i for i in range(len(x)) if ox[i] and not oy[i]]
    y_only = [i for i in range(len(x)) if oy[i] and not ox[i]]
    both = sum(1 for i in range(len(x)) if ox[i] and oy[i])
    print(f"{path}: {len(x)} gaze samples; x-only outliers {len(x_only)}, y-only {len(y_only)}, both {both}")
    for name, v, sel, iqr in (("y at x-only", y, x_only, pct(y, 75) - pct(y, 25)), ("x at y-only", x, y_only, pct(x, 75) - pct(x, 25))):
        r, b = residuals(v, sel)
        if r and b:
            print(f"  {name} outliers: median |off line| {st.median(r):.4f} vs good samples over the same spans {st.median(b):.4f} (axis IQR {iqr:.4f})")


for p in sys.argv[1:]:
    report(p)
