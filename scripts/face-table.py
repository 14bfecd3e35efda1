#!/usr/bin/env python3
"""Visual fidelity of every session of a full-face dataset, one row each.

    python3 scripts/face-table.py DATASET_DIR [DATASET_DIR ...] [--eyereplay PATH]
                                  [--horizontal] [--vertical] [--mesh-every N]
                                  [--iris-views N] [--smooth-s S] [--mediapipe] [--attention]

For each rendered session: `eyereplay extract` (the unmodified path: face
detection, 468 landmarks, iris) reads the video back (kept in
DATASET_DIR/.readback/ under the video's hash), each eye from as many
crops as the session's probe read it (`extractor_iris_views` in its
`_identity.json`, passed as `--iris-views`; `--iris-views N` reads with
N instead); the mean nx, ny of both eyes is compared frame by
frame, open-eye frames only, with the source's position for that frame:
the session's drawn truth mapped through its `extractor_response` (the
renderer draws the inverse of that map, so this is the trajectory's own
normalized position). Prints face detection, r, amplitude ratio
(std ratio) and gain (slope) per axis, the head's yaw range, and a summary
per class.

With --vertical, a second table says where the vertical read-back's error
comes from, per session: the vertical movement to be read in image pixels
(the source's ny std times the extracted lid-to-lid height, mean of both
eyes), the extractor's own error on the iris centre's height (std of the
extracted minus the drawn iris centre, px, mean of both eyes), and the
vertical r again with the drawn iris centre put in place of the extracted
one (lids and corners still the extractor's): what r would be if the iris
network found the iris centre exactly; then the gain (slope of the
read-back on the source) and the gain with the drawn head pose held (the
source's coefficient with the six head-pose columns of _head.csv as
further regressors): where the two differ, the read-back moves with the
head in a way the renderer's pose correction did not cancel. --horizontal gives the same table
for x: the movement is the source's nx std times the extracted
corner-to-corner width, the error is taken along the corner-to-corner axis.

With --smooth-s S, a last table gives each session's r per axis again with
the source and the read-back both smoothed by a Gaussian of S seconds (sd)
over the compared frames: whether a user's smoothing of the extracted
trajectory would remove the read-back's error (frame-to-frame jitter) or
not (an error that drifts over seconds).
With --attention, `eyereplay extract --landmarks attention` (MediaPipe's
attention face mesh) reads the videos instead (kept in
DATASET_DIR/.readback_attention/): how that network reads sessions that
were matched to the cascade (only r compares).
With --mediapipe, MediaPipe's own Python face mesh (refine_landmarks=True,
scripts/dev/mediapipe_ref.sh, which sets up its venv on first use) reads
the videos instead (kept in DATASET_DIR/.readback_mediapipe/): how the
peer tool reads the same frames. The sessions were drawn through our
extractor's response, so its gains need not be 1; r does not depend on them.
With several DATASET_DIRs (the same config at several seeds, say), each
gets its tables, then a pooled summary per class adds the means of r and
of |gain - 1| and the count of amplitude ratios outside 0.9-1.1: one run
moves single sessions by about 0.01, so comparisons of renderer versions
rest on those. scripts/dev/face-seeds.sh makes such datasets.
Exit status 0; it measures, it does not judge.
"""
import argparse, csv, hashlib, json, math, os, subprocess, sys


def video_key(path):
    """The first 12 hex digits of the file's sha256."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()[:12]


def pearson(a, b):
    n = len(a)
    ma, mb = sum(a) / n, sum(b) / n
    saa = sum((x - ma) ** 2 for x in a)
    sbb = sum((y - mb) ** 2 for y in b)
    sab = sum((x - ma) * (y - mb) for x, y in zip(a, b))
    if saa <= 0 or sbb <= 0:
        return float("nan"), float("nan"), float("nan")
    return sab / math.sqrt(saa * sbb), math.sqrt(sbb / saa), sab / saa


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("dataset", nargs="+",
                    help="dataset folders; with several, a pooled summary per class follows")
    here = os.path.dirname(os.path.abspath(__file__))
    ap.add_argument("--eyereplay", default=os.path.join(here, "..", "target", "release", "eyereplay"))
    ap.add_argument("--vertical", action="store_true",
                    help="also the vertical error budget per session (see above)")
    ap.add_argument("--horizontal", action="store_true",
                    help="also the horizontal error budget per session (see above)")
    ap.add_argument("--mesh-every", type=int, metavar="N",
                    help="read back with `eyereplay extract --mesh-every N` (kept in "
                         "DATASET_DIR/.readback_meshN/) instead of the extractor's default")
    ap.add_argument("--mediapipe", action="store_true",
                    help="read back with MediaPipe's own Python face mesh "
                         "(refine_landmarks=True, scripts/dev/mediapipe_ref.sh; kept in "
                         "DATASET_DIR/.readback_mediapipe/) instead of `eyereplay extract`")
    ap.add_argument("--attention", action="store_true",
                    help="read back with `eyereplay extract --landmarks attention` (MediaPipe's "
                         "attention face mesh; kept in DATASET_DIR/.readback_attention/) instead "
                         "of the cascade the sessions were matched to (only r then compares)")
    ap.add_argument("--iris-views", type=int, metavar="N",
                    help="read every session back with `eyereplay extract --iris-views N` "
                         "instead of the crops per eye its probe read with (only r then "
                         "compares: the drawn response is the probe's)")
    ap.add_argument("--smooth-s", type=float, metavar="S",
                    help="also r with source and read-back smoothed by a Gaussian of S s")
    a = ap.parse_args()
    if a.mediapipe and (a.mesh_every is not None or a.vertical or a.horizontal):
        ap.error("--mediapipe reads no iris or corner pixels: it cannot take "
                 "--mesh-every, --vertical or --horizontal")
    if a.attention and (a.mediapipe or a.mesh_every is not None or a.iris_views is not None):
        ap.error("--attention reads with the attention face mesh: it cannot take --mediapipe, "
                 "--mesh-every or --iris-views")
    if a.mediapipe and a.iris_views is not None:
        ap.error("--mediapipe reads with MediaPipe's own crops: it cannot take --iris-views")
    if a.iris_views is not None and not 1 <= a.iris_views <= 9:
        ap.error(f"--iris-views must be from 1 to 9, not {a.iris_views}")
    if a.smooth_s is not None and not a.smooth_s > 0:
        ap.error(f"--smooth-s must be a positive number of seconds, not {a.smooth_s}")
    # Every folder checked before any read-back starts.
    for d in a.dataset:
        for need in ("labels.csv", "metadata.json"):
            if not os.path.isfile(os.path.join(d, need)):
                sys.exit(f"face-table: {os.path.join(d, need)}: no such file (is {d} a dataset "
                         "folder written by `eyereplay generate`?)")
    pooled = []
    for k, d in enumerate(a.dataset):
        if len(a.dataset) > 1:
            print(("\n" if k else "") + f"== {d}")
        pooled += dataset_table(d, a, here)
    if len(a.dataset) > 1:
        print()
        print(f"pooled over {len(a.dataset)} datasets:")
        summary(pooled, pooled_stats=True)


def dataset_table(d, a, here):
    """Reads back every session of dataset `d`, prints its tables, and
    returns its rows (see `summary`)."""
    labels = list(csv.DictReader(open(os.path.join(d, "labels.csv"))))
    out = os.path.join(d, ".readback_mediapipe" if a.mediapipe
                       else ".readback_attention" if a.attention
                       else ".readback" if a.mesh_every is None else f".readback_mesh{a.mesh_every}")
    extra = ([] if a.mesh_every is None else ["--mesh-every", str(a.mesh_every)]) + \
        (["--landmarks", "attention"] if a.attention else [])
    os.makedirs(out, exist_ok=True)
    rows = []
    budget = []
    budget_x = []
    smoothed = []
    fps = float(json.load(open(os.path.join(d, "metadata.json")))["fps"])
    for lab in labels:
        f = lab.get("file") or lab.get("path") or list(lab.values())[0]
        stem = os.path.join(d, f[:-4])
        mp4, truth, head, ident = stem + ".mp4", stem + "_truth.csv", stem + "_head.csv", stem + "_identity.json"
        if not (os.path.exists(mp4) and os.path.exists(truth)):
            continue
        # The crops per eye the session was matched to
        # (render.extractor_iris_views), read back the same way. A
        # read-back is kept under the video's own hash and that setting,
        # so a regenerated dataset is never compared with an old one.
        views = 1
        if a.iris_views is not None:
            views = a.iris_views
        elif not a.mediapipe and not a.attention and os.path.exists(ident):
            views = int(json.load(open(ident)).get("extractor_iris_views") or 1)
        name = f.replace("/", "__")[:-len(".csv")] + "." + video_key(mp4)
        if views > 1:
            name += f".views{views}"
        x = os.path.join(out, name + ".csv")
        if not os.path.exists(x):
            # Written whole, then renamed: an interrupted run leaves no
            # half file that a later run would take as done.
            # (`eyereplay extract` takes an --out without .csv for a folder.)
            tmp = x[:-len(".csv")] + ".part.csv"
            if a.mediapipe:
                cmd = [os.path.join(here, "dev", "mediapipe_ref.sh"), mp4, tmp]
            else:
                cmd = [a.eyereplay, "extract", mp4, "--out", tmp, "--iris-views", str(views)] + extra
            run = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
            if run.returncode != 0:
                if os.path.exists(tmp):
                    os.remove(tmp)
                last = (run.stderr.strip().splitlines() or ["no message"])[-1]
                sys.exit(f"face-table: reading back {mp4} failed (exit {run.returncode}): {last}")
            os.replace(tmp, x)
        ex = list(csv.DictReader(open(x)))
        if a.mediapipe:
            ex = [mediapipe_row(e) for e in ex]
        tr = list(csv.DictReader(open(truth)))
        idn = json.load(open(ident))
        mp = idn["mapping"]
        cal, g = mp["calibration"], mp.get("gain", 1.0)
        # Blinks widened by two frames each side (the lids are part-closed
        # just before and after), as `eyereplay evaluate` does.
        blink = [t["blink"] == "1" for t in tr]
        closed = [any(blink[max(0, k - 2):k + 3]) for k in range(len(blink))]
        # The compared frames: a valid read-back, eyes open.
        kept = [(e, t) for e, t, c in zip(ex, tr, closed) if e["valid"] == "1" and not c]
        frames = [k for k, (e, c) in enumerate(zip(ex, closed)) if e["valid"] == "1" and not c]
        pts = []
        for e, t in kept:
            sx = 0.5 + g * (float(t["x"]) - cal["mu_x"]) / cal["s_x"]
            sy = 0.5 + g * (float(t["y"]) - cal["mu_y"]) / cal["s_y"]
            pts.append((sx, sy, float(e["nx"]), float(e["ny"])))
        face = sum(1 for e in ex if e["face"] == "1") / max(1, len(ex))
        rx = pearson([p[0] for p in pts], [p[2] for p in pts])
        ry = pearson([p[1] for p in pts], [p[3] for p in pts])
        head_rows = list(csv.DictReader(open(head))) if os.path.exists(head) else []
        yaw = [float(h["head_yaw_deg"]) for h in head_rows] or [0.0]
        # The drawn head pose at each compared frame (for the gain with the
        # head held, below).
        poses = [[float(head_rows[k][c]) for c in HEAD_COLUMNS] for k in frames] if head_rows else None
        cls = f.split("/")[0]
        photo = idn.get("identity", {}).get("photo", "?")
        rows.append((f, cls, photo, face, len(pts), rx, ry, min(yaw), max(yaw)))
        if a.smooth_s:
            sd_frames = a.smooth_s * fps
            smoothed.append((f, [pearson(gauss_smooth(frames, [p[i] for p in pts], sd_frames),
                                         gauss_smooth(frames, [p[i + 2] for p in pts], sd_frames))[0]
                                 for i in (0, 1)]))
        if a.vertical:
            budget.append((f, error_budget(kept, [p[1] for p in pts], "y")
                           + (gain_with_head([p[1] for p in pts], [p[3] for p in pts], poses),)))
        if a.horizontal:
            budget_x.append((f, error_budget(kept, [p[0] for p in pts], "x")
                             + (gain_with_head([p[0] for p in pts], [p[2] for p in pts], poses),)))
    print(f"{'session':<34} {'photo':<20} {'face':>6} {'n':>5} {'x r':>6} {'x ratio':>7} {'x gain':>6} {'y r':>6} {'y ratio':>7} {'y gain':>6} {'yaw deg':>12}")
    for f, cls, photo, face, n, rx, ry, y0, y1 in rows:
        print(f"{f:<34} {photo:<20} {100*face:5.1f}% {n:5d} {rx[0]:6.3f} {rx[1]:7.2f} {rx[2]:6.2f} {ry[0]:6.3f} {ry[1]:7.2f} {ry[2]:6.2f} {y0:5.1f}..{y1:4.1f}")
    summary(rows)
    if budget:
        print()
        print(f"{'session':<34} {'y r':>6} {'signal px':>9} {'iris err px':>11} {'y r, drawn iris':>15} {'y gain':>6} {'head held':>9}")
        for (f, (sig, err, r_alt, g_head)), row in zip(budget, rows):
            print(f"{f:<34} {row[6][0]:6.3f} {sig:9.2f} {err:11.2f} {r_alt:15.3f} {row[6][2]:6.2f} {g_head:9.2f}")
    if budget_x:
        print()
        print(f"{'session':<34} {'x r':>6} {'signal px':>9} {'iris err px':>11} {'x r, drawn iris':>15} {'x gain':>6} {'head held':>9}")
        for (f, (sig, err, r_alt, g_head)), row in zip(budget_x, rows):
            print(f"{f:<34} {row[5][0]:6.3f} {sig:9.2f} {err:11.2f} {r_alt:15.3f} {row[5][2]:6.2f} {g_head:9.2f}")
    if smoothed:
        print()
        print(f"{'session':<34} {'x r':>6} {'smoothed':>8} {'y r':>6} {'smoothed':>8}   (Gaussian sd {a.smooth_s} s)")
        for (f, (sx, sy)), row in zip(smoothed, rows):
            print(f"{f:<34} {row[5][0]:6.3f} {sx:8.3f} {row[6][0]:6.3f} {sy:8.3f}")
    return rows


def summary(rows, pooled_stats=False):
    """One line per class of `rows` (session, class, photo, face share,
    frames, (r, ratio, gain) in x, the same in y, yaw range): ranges of
    face found, r and amplitude ratio per axis; pooled over several
    datasets, also the means of r and of |gain - 1| and how many amplitude
    ratios fall outside 0.9-1.1 (the figures a comparison over seeds
    rests on: one run moves single sessions by about 0.01)."""
    for cls in sorted({r[1] for r in rows}):
        sel = [r for r in rows if r[1] == cls]
        rng = lambda k, i: (min(r[k][i] for r in sel), max(r[k][i] for r in sel))
        print(f"{cls}: {len(sel)} sessions, face {100*min(r[3] for r in sel):.1f}-{100*max(r[3] for r in sel):.1f} %, "
              f"x r {rng(5,0)[0]:.3f}-{rng(5,0)[1]:.3f}, x ratio {rng(5,1)[0]:.2f}-{rng(5,1)[1]:.2f}, "
              f"y r {rng(6,0)[0]:.3f}-{rng(6,0)[1]:.3f}, y ratio {rng(6,1)[0]:.2f}-{rng(6,1)[1]:.2f}")
        if pooled_stats:
            mean = lambda v: sum(v) / len(v)
            out = lambda k: sum(1 for r in sel if not 0.9 <= r[k][1] <= 1.1)
            print(f"  mean x r {mean([r[5][0] for r in sel]):.4f}, mean y r {mean([r[6][0] for r in sel]):.3f}, "
                  f"mean |x gain - 1| {mean([abs(r[5][2] - 1) for r in sel]):.3f}, "
                  f"mean |y gain - 1| {mean([abs(r[6][2] - 1) for r in sel]):.3f}, "
                  f"ratios outside 0.9-1.1: x {out(5)}, y {out(6)} of {len(sel)}")


def mediapipe_row(e):
    """A row of mediapipe_ref.py's CSV in `eyereplay extract`'s terms: the
    face found, valid when found, nx and ny the mean of both eyes."""
    found = e["detected"] == "1"
    mean = lambda k: str((float(e[k + "_l"]) + float(e[k + "_r"])) / 2) if found else ""
    return {"face": e["detected"], "valid": e["detected"], "nx": mean("nx"), "ny": mean("ny")}


HEAD_COLUMNS = ("head_yaw_deg", "head_pitch_deg", "head_roll_deg", "head_x_cm", "head_y_cm", "head_z_cm")


def gain_with_head(target, read, poses):
    """The read-back's gain on the source with the drawn head pose held:
    the source's coefficient when `read` is regressed on the source and
    the six head-pose columns together (least squares, with an intercept).
    Where the head's pose follows the eye (reading's pitch follows the
    eye's height), a reading that moves with the head shows up in the plain
    gain; here it does not. NaN without a head file or with a singular fit."""
    if not poses or len(target) < 10:
        return float("nan")
    rows = [[t] + p + [1.0] for t, p in zip(target, poses)]
    k = len(rows[0])
    # Normal equations, columns scaled to unit sd so the solve is well
    # conditioned; then Gaussian elimination with partial pivoting.
    sd = [std([r[j] for r in rows]) or 1.0 for j in range(k - 1)] + [1.0]
    rows = [[v / sd[j] for j, v in enumerate(r)] for r in rows]
    a = [[sum(r[i] * r[j] for r in rows) for j in range(k)] + [sum(r[i] * y for r, y in zip(rows, read))]
         for i in range(k)]
    for c in range(k):
        piv = max(range(c, k), key=lambda i: abs(a[i][c]))
        if abs(a[piv][c]) < 1e-12:
            return float("nan")
        a[c], a[piv] = a[piv], a[c]
        for i in range(k):
            if i != c:
                f = a[i][c] / a[c][c]
                a[i] = [x - f * y for x, y in zip(a[i], a[c])]
    return a[0][k] / a[0][0] / sd[0]


def gauss_smooth(frames, values, sd_frames):
    """`values` at frame numbers `frames` (increasing, with gaps where
    frames were left out), each replaced by the Gaussian-weighted mean (sd
    `sd_frames`, cut at 4 sd) of the values at the frames around it: gaps
    get no weight rather than a made-up value."""
    reach = int(4 * sd_frames)
    out = []
    lo = 0
    for k, fk in enumerate(frames):
        while frames[lo] < fk - reach:
            lo += 1
        num = den = 0.0
        j = lo
        while j < len(frames) and frames[j] <= fk + reach:
            w = math.exp(-0.5 * ((frames[j] - fk) / sd_frames) ** 2)
            num += w * values[j]
            den += w
            j += 1
        out.append(num / den)
    return out


def std(v):
    m = sum(v) / len(v)
    return math.sqrt(sum((x - m) ** 2 for x in v) / len(v))


def error_budget(kept, target, axis):
    """(signal px, iris error px, r with the drawn iris centre) of one
    session along `axis` ("x" or "y"): `kept` the compared (read-back row,
    truth row) pairs, `target` the source's n on that axis at each.

    x: nx is measured along each eye's corner-to-corner axis in eye widths,
    so the movement and the iris error are taken along that axis. y: ny is
    measured in lid-to-lid heights (the aperture is in eye widths), the error
    on the image's y."""
    if len(target) < 3:
        return float("nan"), float("nan"), float("nan")
    lengths, errors, n_alt = [], [], []
    for side in ("left", "right"):
        len_px, dev, alt = [], [], []
        for e, t in kept:
            ux = float(e[f"{side}_eye_right_corner_x_px"]) - float(e[f"{side}_eye_left_corner_x_px"])
            uy = float(e[f"{side}_eye_right_corner_y_px"]) - float(e[f"{side}_eye_left_corner_y_px"])
            w = math.hypot(ux, uy)
            # The drawn minus the extracted iris centre.
            dx = float(t[f"{side}_iris_x_px"]) - float(e[f"iris_{side}_x_px"])
            dy = float(t[f"{side}_iris_y_px"]) - float(e[f"iris_{side}_y_px"])
            if axis == "x":
                length, d = w, (dx * ux + dy * uy) / w
            else:
                length, d = float(e[f"aperture_{side}"]) * w, dy
            len_px.append(length)
            dev.append(d)
            # n moves by d / length when the iris centre moves by d px (an
            # open eye: `kept` holds no blink frames, so length > 0).
            alt.append(float(e[f"n{axis}_{side}"]) + d / length)
        lengths.append(sum(len_px) / len(len_px))
        errors.append(std(dev))
        n_alt.append(alt)
    sig = std(target) * sum(lengths) / 2
    alt = [(l + r) / 2 for l, r in zip(*n_alt)]
    return sig, sum(errors) / 2, pearson(target, alt)[0]


if __name__ == "__main__":
    sys.exit(main())
