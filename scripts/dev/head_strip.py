#!/usr/bin/env python3
"""Source head against rendered head (docs/img/head_strip.jpg).

    scripts/dev/head_strip.py DATASET OUT.jpg [--from CONFIG_DIR] [--session FILE] [--frames 4]

For a full-face dataset made with `head_motion = "source"`: one session's
frames where its head turns most (spread over the session), the source
video's frame at the same moment above (found through pool/<class>.csv's
source and source_t_s), the rendered frame below, each labelled with the
head yaw of `_head.csv`. Source paths in metadata.json are relative to the
config's folder: give it with --from (e.g. `--from examples`), or run from there.
Needs ffmpeg and Pillow (a developer tool, not part of the pipeline).
"""
import argparse, csv, json, os, subprocess, tempfile
from PIL import Image, ImageDraw

ap = argparse.ArgumentParser()
ap.add_argument("dataset"); ap.add_argument("out")
ap.add_argument("--session", help="e.g. conversation/conversation_0001.csv (default: the "
                "session whose head yaw spans most)")
ap.add_argument("--frames", type=int, default=4)
ap.add_argument("--from", dest="config_dir", default=".",
                help="the folder of the dataset's config, where its relative source paths start "
                "(default: the current folder)")
a = ap.parse_args()

meta = json.load(open(os.path.join(a.dataset, "metadata.json")))
sessions = [s for s in meta["sessions"]
            if os.path.exists(os.path.join(a.dataset, s["file"][:-4] + "_head.csv"))]

def head(s):
    return [float(r["head_yaw_deg"]) for r in
            csv.DictReader(open(os.path.join(a.dataset, s["file"][:-4] + "_head.csv")))]

if a.session:
    s = next(x for x in sessions if x["file"] == a.session)
else:
    s = max(sessions, key=lambda x: max(head(x)) - min(head(x)))
yaw = head(s)
pool = list(csv.DictReader(open(os.path.join(a.dataset, "pool", s["class"] + ".csv"))))
T, n = len(pool), len(yaw)
# Frames: the two extremes of yaw, then evenly spread others not too close
# to a frame already taken, in time order.
lo = min(range(n), key=lambda j: yaw[j])
hi = max(range(n), key=lambda j: yaw[j])
picks = [lo, hi]
for k in range(a.frames):
    j = int((k + 0.5) * n / a.frames)
    if len(picks) < a.frames and all(abs(j - p) > n / (2 * a.frames) for p in picks):
        picks.append(j)
picks = sorted(picks)

tmp = tempfile.mkdtemp()
def grab(video, t_s=None, n=None):
    p = os.path.join(tmp, "f.png")
    sel = ["-ss", f"{t_s:.3f}"] if t_s is not None else []
    vf = [] if n is None else ["-vf", f"select=eq(n\\,{n})"]
    subprocess.run(["ffmpeg", "-v", "error", "-y", *sel, "-i", video, *vf,
                    "-frames:v", "1", p], check=True)
    return Image.open(p).convert("RGB")

W = 240
cols = []
for j in picks:
    row = pool[(s["pool_start"] + j) % T]
    src = meta["sources"][int(row["source"])]
    video = os.path.join(a.config_dir, src["file"])
    if not os.path.exists(video):
        raise SystemExit(f"error: {video}: source video not found (its path is relative to the "
                         "config's folder: give that folder with --from)")
    before = grab(video, t_s=float(row["source_t_s"]))
    after = grab(os.path.join(a.dataset, s["file"][:-4] + ".mp4"), n=j)
    fit = lambda im: im.resize((W, int(im.height * W / im.width)), Image.LANCZOS)
    cols.append((fit(before), fit(after), j, yaw[j], os.path.basename(src["file"])))

hb = max(c[0].height for c in cols); ha = max(c[1].height for c in cols)
pad, lab = 6, 18
img = Image.new("RGB", (len(cols) * (W + pad) + pad, hb + ha + 2 * lab + 3 * pad), "white")
d = ImageDraw.Draw(img)
for i, (b, r, j, y, name) in enumerate(cols):
    x = pad + i * (W + pad)
    d.text((x, pad), f"source {name} t={float(pool[(s['pool_start'] + j) % T]['source_t_s']):.1f}s", fill="black")
    img.paste(b, (x, pad + lab))
    d.text((x, 2 * pad + lab + hb), f"rendered frame {j}: head yaw {y:+.1f} deg", fill="black")
    img.paste(r, (x, 2 * pad + 2 * lab + hb))
img.save(a.out, quality=88)
print(f"{a.out}: {s['file']}, frames {picks}")
