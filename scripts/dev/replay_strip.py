#!/usr/bin/env python3
"""Before/after strip of a replay dataset (docs/img/replay_strip.jpg).

    scripts/dev/replay_strip.py DATASET OUT.png [--frame K]

One column per carrier (its first session in labels.csv): the carrier's
frame, the replayed frame, and both as close-ups of the eyes. Needs ffmpeg
and Pillow (a developer tool, not part of the pipeline).
"""
import argparse, csv, json, os, subprocess, tempfile
from PIL import Image, ImageDraw

ap = argparse.ArgumentParser()
ap.add_argument("dataset"); ap.add_argument("out")
ap.add_argument("--frame", type=int, default=160)
a = ap.parse_args()

def frame(video, n, path):
    subprocess.run(["ffmpeg", "-v", "error", "-y", "-i", video, "-vf",
                    f"select=eq(n\\,{n})", "-frames:v", "1", path], check=True)
    return Image.open(path).convert("RGB")

cfg = json.load(open(os.path.join(a.dataset, "metadata.json")))
carriers_dir = None
seen, cols = set(), []
tmp = tempfile.mkdtemp()
for row in csv.DictReader(open(os.path.join(a.dataset, "labels.csv"))):
    stem = os.path.join(a.dataset, row["file"][:-4])
    ident = json.load(open(stem + "_identity.json"))["identity"]
    name = ident["carrier"]
    if name in seen:
        continue
    rows = list(csv.DictReader(open(stem + "_carrier.csv")))
    k = next(i for i in range(a.frame, len(rows)) if rows[i]["redrawn"] == "1")
    r = rows[k]
    src = os.path.join(os.environ.get("EYEREPLAY_CACHE", ".cache"), "carriers", name)
    before = frame(src, int(r["carrier_frame"]), os.path.join(tmp, "b.png"))
    after = frame(stem + ".mp4", k, os.path.join(tmp, "a.png"))
    lx, ly, rx, ry = (float(r[c]) for c in
                      ["left_iris_x_px", "left_iris_y_px", "right_iris_x_px", "right_iris_y_px"])
    cx, cy, d = (lx + rx) / 2, (ly + ry) / 2, abs(rx - lx)
    face = (int(cx - 1.6 * d), int(cy - 1.3 * d), int(cx + 1.6 * d), int(cy + 2.3 * d))
    eyes = (int(cx - 0.95 * d), int(cy - 0.3 * d), int(cx + 0.95 * d), int(cy + 0.3 * d))
    W = 300
    def fit(img, box, w):
        c = img.crop(box)
        return c.resize((w, int(c.height * w / c.width)), Image.LANCZOS)
    cols.append([fit(before, face, W), fit(after, face, W),
                 fit(before, eyes, W), fit(after, eyes, W), name])
    seen.add(name)
H = sum(im.height for im in cols[0][:4]) + 5 * 6 + 20
strip = Image.new("RGB", (len(cols) * (W + 6) + 6, H), "white")
draw = ImageDraw.Draw(strip)
for i, col in enumerate(cols):
    x, y = 6 + i * (W + 6), 6
    draw.text((x, y), col[4], fill="black")
    y += 14
    for im in col[:4]:
        strip.paste(im, (x, y)); y += im.height + 6
strip.save(a.out)
print(f"wrote {a.out}: {len(cols)} carriers (rows: carrier, replayed, carrier eyes, replayed eyes)")
