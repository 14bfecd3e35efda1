#!/usr/bin/env python3
"""MediaPipe Python face mesh reference for eyereplay's iris extraction.

Runs the legacy `mp.solutions.face_mesh.FaceMesh(refine_landmarks=True)` of
the mediapipe==0.10.21 wheel on every frame of a video (decoded with OpenCV,
decoding included in the timing) and writes, per frame, the iris position
normalised within each eye with the paper's formula, using the same
conventions as `eyereplay extract`:

  eye l = the eye on the image's left, eye r = the one on the image's right;
  nx = (iris_x - left_corner_x) / (right_corner_x - left_corner_x)  (image direction, both eyes)
  ny = (iris_y - upper_lid_y) / (lower_lid_y - upper_lid_y)
  ap = |lower_lid - upper_lid| / |right_corner - left_corner|  (aperture)

Mesh points: corners 33/133 and 362/263, lids 159/145 and 386/374, iris
centres 468/473 (with refine_landmarks these eye points come from the
refinement networks, as in MediaPipe's iris tracking).

Usage: mediapipe_ref.py VIDEO [OUT.csv]   (prints `fps=<frames/s>` at the end)
"""
import sys
import time

import cv2
import mediapipe as mp

EYES = {  # image-left eye first when the face is upright and not mirrored
    "a": dict(c0=33, c1=133, top=159, bot=145, iris=468),
    "b": dict(c0=362, c1=263, top=386, bot=374, iris=473),
}


def eye_values(lm, w, h, e):
    p = lambda i: (lm[i].x * w, lm[i].y * h)
    c0, c1, top, bot, iris = (p(e[k]) for k in ("c0", "c1", "top", "bot", "iris"))
    if c1[0] < c0[0]:
        c0, c1 = c1, c0
    dx = c1[0] - c0[0]
    dy = bot[1] - top[1]
    nx = (iris[0] - c0[0]) / dx if dx else float("nan")
    ny = (iris[1] - top[1]) / dy if dy else float("nan")
    width = ((c1[0] - c0[0]) ** 2 + (c1[1] - c0[1]) ** 2) ** 0.5
    gap = ((bot[0] - top[0]) ** 2 + (bot[1] - top[1]) ** 2) ** 0.5
    return nx, ny, gap / width if width else float("nan"), (c0[0] + c1[0]) / 2


def main():
    if len(sys.argv) not in (2, 3):
        raise SystemExit(__doc__)
    out = open(sys.argv[2], "w") if len(sys.argv) == 3 else None
    if out:
        out.write("frame,time_s,detected,nx_l,ny_l,nx_r,ny_r,aperture_l,aperture_r\n")
    cap = cv2.VideoCapture(sys.argv[1])
    mesh = mp.solutions.face_mesh.FaceMesh(
        static_image_mode=False, max_num_faces=1, refine_landmarks=True,
        min_detection_confidence=0.5, min_tracking_confidence=0.5)
    n = 0
    t0 = time.perf_counter()
    while True:
        ok, bgr = cap.read()
        if not ok:
            break
        t_s = cap.get(cv2.CAP_PROP_POS_MSEC) / 1000.0
        h, w = bgr.shape[:2]
        res = mesh.process(cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB))
        if out:
            if res.multi_face_landmarks:
                lm = res.multi_face_landmarks[0].landmark
                a = eye_values(lm, w, h, EYES["a"])
                b = eye_values(lm, w, h, EYES["b"])
                l, r = (a, b) if a[3] <= b[3] else (b, a)
                out.write(f"{n},{t_s:.6f},1,{l[0]:.4f},{l[1]:.4f},{r[0]:.4f},{r[1]:.4f},{l[2]:.4f},{r[2]:.4f}\n")
            else:
                out.write(f"{n},{t_s:.6f},0,,,,,,\n")
        n += 1
    dt = time.perf_counter() - t0
    if out:
        out.close()
    print(f"frames={n} seconds={dt:.3f} fps={n / dt:.1f}")


if __name__ == "__main__":
    main()
