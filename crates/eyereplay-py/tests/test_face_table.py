"""scripts/face-table.py's error budget, against cases worked by hand."""

import importlib.util
import math

import pytest

from conftest import ROOT


def face_table():
    spec = importlib.util.spec_from_file_location("face_table", ROOT / "scripts" / "face-table.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def pair(corner_a, corner_b, iris, drawn, n, aperture=0.25):
    """One (read-back row, truth row) pair with both eyes alike: corners and
    iris centre as extracted, the drawn iris centre, and the eyes' n."""
    e, t = {}, {}
    for side in ("left", "right"):
        e[f"{side}_eye_left_corner_x_px"], e[f"{side}_eye_left_corner_y_px"] = corner_a
        e[f"{side}_eye_right_corner_x_px"], e[f"{side}_eye_right_corner_y_px"] = corner_b
        e[f"iris_{side}_x_px"], e[f"iris_{side}_y_px"] = iris
        t[f"{side}_iris_x_px"], t[f"{side}_iris_y_px"] = drawn
        e[f"nx_{side}"], e[f"ny_{side}"] = n
        e[f"aperture_{side}"] = aperture
    return e, t


# Movement s px and iris error d px per frame: std(s) = sqrt(10 / 4), std(d)
# = 1, and r(s, s + d) = 8 / sqrt(10 * 10) = 0.8.
S = [-2.0, -1.0, 1.0, 2.0]
D = [1.0, -1.0, 1.0, -1.0]


def assert_worked_by_hand(kept, target, axis):
    """Every case below: movement sqrt(10 / 4) px, error 1 px, r 0.8."""
    sig, err, r = face_table().error_budget(kept, target, axis)
    assert sig == pytest.approx(math.sqrt(10 / 4))
    assert err == pytest.approx(1.0)
    assert r == pytest.approx(0.8)


def test_horizontal_budget_along_a_level_eye():
    w = 40.0
    kept = [pair((0, 0), (w, 0), (20 + s, 5), (20 + s + d, 5), (0.5 + s / w, 0.4)) for s, d in zip(S, D)]
    assert_worked_by_hand(kept, [0.5 + s / w for s in S], "x")


def test_horizontal_budget_takes_the_error_along_the_corner_axis():
    # An eye turned 90 degrees: its corner axis is the image's y, so an
    # error on the image's x does not move nx and one on y does.
    w = 40.0
    kept = [pair((0, 0), (0, w), (5, 20 + s), (5 + 3.0, 20 + s + d), (0.5 + s / w, 0.4)) for s, d in zip(S, D)]
    assert_worked_by_hand(kept, [0.5 + s / w for s in S], "x")


def test_vertical_budget_in_lid_to_lid_heights():
    # Eye 40 px wide, aperture 0.25 of its width: lid to lid 10 px.
    w, h = 40.0, 10.0
    kept = [pair((0, 0), (w, 0), (20, 5 + s), (20, 5 + s + d), (0.5, 0.5 + s / h)) for s, d in zip(S, D)]
    assert_worked_by_hand(kept, [0.5 + s / h for s in S], "y")


def test_smoothing_weighs_neighbours_by_a_gaussian_and_skips_gaps():
    smooth = face_table().gauss_smooth
    # A constant stays constant; a value alone within reach stays itself.
    assert smooth([0, 1, 2], [3.0, 3.0, 3.0], 1.0) == pytest.approx([3.0] * 3)
    assert smooth([0, 10], [1.0, 5.0], 1.0) == pytest.approx([1.0, 5.0])
    # Frames 0, 1 and 3 (2 left out), sd 1 frame: frame 1 weighs frame 0
    # and 1 by exp(-1/2) and 1, frame 3 by exp(-2) (two frames away).
    a, b = math.exp(-0.5), math.exp(-2.0)
    out = smooth([0, 1, 3], [0.0, 1.0, 4.0], 1.0)
    assert out[1] == pytest.approx((a * 0.0 + 1.0 + b * 4.0) / (a + 1.0 + b))
    # Frame 0: itself, frame 1 at exp(-1/2), frame 3 at exp(-9/2).
    c = math.exp(-4.5)
    assert out[0] == pytest.approx((a * 1.0 + c * 4.0) / (1.0 + a + c))


def test_pooled_summary_means_and_counts_worked_by_hand(capsys):
    # Rows as dataset_table returns them: (session, class, photo, face,
    # frames, (r, ratio, gain) in x, the same in y, yaw min, yaw max).
    rows = [
        ("a", "reading", "p", 1.0, 700, (0.99, 1.05, 1.04), (0.80, 1.25, 1.00), -1.0, 1.0),
        ("b", "reading", "p", 1.0, 700, (0.97, 0.85, 0.82), (0.90, 1.00, 0.90), -1.0, 1.0),
        ("c", "conversation", "p", 0.995, 650, (0.95, 1.00, 0.95), (0.70, 1.10, 0.77), -2.0, 2.0),
    ]
    face_table().summary(rows, pooled_stats=True)
    out = capsys.readouterr().out.splitlines()
    # Classes sorted: conversation, then reading; each a range line and a
    # means line.
    assert out[0].startswith("conversation: 1 sessions, face 99.5-99.5 %")
    assert "mean x r 0.9500, mean y r 0.700" in out[1]
    # |0.95 - 1| = 0.05, |0.77 - 1| = 0.23; ratio 1.10 is inside.
    assert "mean |x gain - 1| 0.050, mean |y gain - 1| 0.230" in out[1]
    assert out[1].endswith("ratios outside 0.9-1.1: x 0, y 0 of 1")
    assert out[2].startswith("reading: 2 sessions, face 100.0-100.0 %, x r 0.970-0.990, x ratio 0.85-1.05")
    # x r (0.99 + 0.97) / 2 = 0.98; y r 0.85; |x gain - 1| (0.04 + 0.18) / 2
    # = 0.11; |y gain - 1| (0 + 0.1) / 2 = 0.05; x ratio 0.85 and y ratio
    # 1.25 outside.
    assert "mean x r 0.9800, mean y r 0.850" in out[3]
    assert "mean |x gain - 1| 0.110, mean |y gain - 1| 0.050" in out[3]
    assert out[3].endswith("ratios outside 0.9-1.1: x 1, y 1 of 2")
    # Without pooled_stats, only the range lines.
    face_table().summary(rows)
    assert len(capsys.readouterr().out.splitlines()) == 2
