"""eyereplay.extract() against `eyereplay extract` on a bundled real video,
and against MediaPipe's own output for the same frames."""

import csv
from pathlib import Path

import numpy as np
import pytest

import eyereplay
from conftest import DATA, ROOT, run_cli

VIDEO = DATA / "franck.mp4"
MEDIAPIPE = ROOT / "crates/eyereplay-extract/tests/data/franck_mediapipe.csv"


@pytest.fixture(scope="module")
def both(tmp_path_factory):
    d = tmp_path_factory.mktemp("extract")
    r = run_cli("extract", VIDEO, "--out", d / "cli.csv", "--max-seconds", "6", "--quiet")
    assert r.returncode == 0, r.stderr
    table = eyereplay.extract(VIDEO, out=d / "py.csv", max_seconds=6, progress=False)
    return d, table


def test_csv_is_byte_identical_to_the_cli(both):
    d, _ = both
    assert (d / "py.csv").read_bytes() == (d / "cli.csv").read_bytes()


def test_table_has_the_cli_columns_and_numbers(both):
    d, t = both
    assert t.dtype.names == eyereplay.EXTRACT_COLUMNS
    with open(d / "cli.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(t) == len(rows) > 100
    for i in (0, len(rows) // 2, len(rows) - 1):
        for name in ("frame", "time_s", "valid", "nx", "ny", "blink", "aperture"):
            v = rows[i][name]
            want = float(v) if v else np.nan
            got = float(t[name][i])
            assert (np.isnan(want) and np.isnan(got)) or got == want


def test_agrees_with_mediapipe(both):
    # MediaPipe Python's face mesh (refine_landmarks) on the same video,
    # recorded by scripts/dev/mediapipe_ref.sh: same frames, close n.
    _, t = both
    with open(MEDIAPIPE, newline="") as f:
        ref = {int(r["frame"]): r for r in csv.DictReader(f)}
    ok = []
    for i in range(len(t)):
        r = ref.get(int(t["frame"][i]))
        if t["valid"][i] == 1 and r is not None and r["detected"] == "1":
            # n is the mean of the two eyes' n in both tools
            ok.append((float(t["nx"][i]), (float(r["nx_l"]) + float(r["nx_r"])) / 2))
    a, b = np.array(ok).T
    assert len(a) > 100
    # docs/EXTRACTION.md's table over the whole video: median |dx| 0.008, p95 0.025
    # (r needs the whole video's range; 6 s of one face hardly move).
    dx = np.abs(a - b)
    assert np.median(dx) < 0.015 and np.quantile(dx, 0.95) < 0.04


def test_pandas_frame_has_the_same_values(both):
    pd = pytest.importorskip("pandas")
    d, t = both
    df = eyereplay.extract(VIDEO, max_seconds=6, pandas=True, progress=False)
    assert isinstance(df, pd.DataFrame)
    assert list(df.columns) == list(eyereplay.EXTRACT_COLUMNS)
    assert np.array_equal(df["nx"].to_numpy(), t["nx"], equal_nan=True)


def test_progress_counts_every_frame(both):
    _, t = both
    seen = []

    class P:
        def begin(self, stage, total):
            seen.append(("begin", stage))

        def add_total(self, n):
            pass

        def advance(self, n):
            seen.append(("advance", n))

        def end(self, stage):
            seen.append(("end", stage))

    eyereplay.extract(VIDEO, max_seconds=6, progress=P())
    assert seen[0] == ("begin", "extract") and seen[-1] == ("end", "extract")
    assert sum(n for k, n in seen if k == "advance") == len(t)


def test_iris_views_match_the_cli_and_are_checked(tmp_path):
    # The same more-precise reading as `eyereplay extract --iris-views 3`,
    # byte for byte; out-of-range counts are a ConfigError before any work.
    r = run_cli("extract", VIDEO, "--out", tmp_path / "cli.csv", "--max-seconds", "2",
                "--iris-views", "3", "--quiet")
    assert r.returncode == 0, r.stderr
    eyereplay.extract(VIDEO, out=tmp_path / "py.csv", max_seconds=2, iris_views=3,
                      progress=False)
    assert (tmp_path / "py.csv").read_bytes() == (tmp_path / "cli.csv").read_bytes()
    one = eyereplay.extract(VIDEO, max_seconds=2, landmarks="cascade", progress=False)
    three = eyereplay.extract(VIDEO, max_seconds=2, iris_views=3, progress=False)
    both = (one["valid"] == 1) & (three["valid"] == 1)
    assert both.sum() > 30
    d = np.abs(one["nx"][both] - three["nx"][both])
    # Other crops, another reading: close, not the same.
    assert 0 < np.median(d) < 0.02
    for bad in (0, 10):
        with pytest.raises(eyereplay.ConfigError, match="iris_views"):
            eyereplay.extract(VIDEO, max_seconds=1, iris_views=bad, progress=False)


def test_default_landmarks_are_the_attention_mesh_and_are_checked(tmp_path):
    # MediaPipe's attention face mesh is the default (`--landmarks
    # attention`), byte for byte as the command writes it; the cascade is
    # another network, so other numbers; an unknown name, or an option of
    # the cascade asked of the attention mesh, is a ConfigError.
    r = run_cli("extract", VIDEO, "--out", tmp_path / "cli.csv", "--max-seconds", "2",
                "--landmarks", "attention", "--quiet")
    assert r.returncode == 0, r.stderr
    eyereplay.extract(VIDEO, out=tmp_path / "py.csv", max_seconds=2, progress=False)
    assert (tmp_path / "py.csv").read_bytes() == (tmp_path / "cli.csv").read_bytes()
    cascade = eyereplay.extract(VIDEO, max_seconds=2, landmarks="cascade", progress=False)
    attention = eyereplay.extract(VIDEO, max_seconds=2, progress=False)
    both = (cascade["valid"] == 1) & (attention["valid"] == 1)
    assert both.sum() > 30
    assert 0 < np.median(np.abs(cascade["nx"][both] - attention["nx"][both])) < 0.05
    # mesh_every is the cascade's: given alone it selects the cascade.
    every = eyereplay.extract(VIDEO, max_seconds=2, mesh_every=2, progress=False)
    assert np.array_equal(every["nx"], cascade["nx"], equal_nan=True)
    with pytest.raises(eyereplay.ConfigError, match="landmarks"):
        eyereplay.extract(VIDEO, max_seconds=1, landmarks="iris", progress=False)
    with pytest.raises(eyereplay.ConfigError,
                       match=r'^iris_views applies to the cascade .*use landmarks="cascade"'):
        eyereplay.extract(VIDEO, max_seconds=1, landmarks="attention", iris_views=5,
                          progress=False)
