"""Shared fixtures. The tests run against the installed wheel (a fresh venv
made by scripts/python-test.sh) and compare it with the `eyereplay` binary
named by $EYEREPLAY_BIN, on the repository's bundled sample data."""

import os
import subprocess
from pathlib import Path

import pytest

ROOT = Path(os.environ.get("EYEREPLAY_ROOT", Path(__file__).resolve().parents[3]))
DATA = ROOT / ".cache" / "data"


def cli_binary() -> Path:
    b = os.environ.get("EYEREPLAY_BIN")
    if not b:
        pytest.fail("EYEREPLAY_BIN is not set: run scripts/python-test.sh")
    return Path(b)


def run_cli(*args, cwd=None) -> subprocess.CompletedProcess:
    return subprocess.run(
        [str(cli_binary()), *map(str, args)], capture_output=True, text=True, cwd=cwd
    )


def small_config(out_size=(320, 180)) -> dict:
    """The bundled default sample, shrunk to 2 sessions of 4 s per class."""
    return {
        "fps": 25.0,
        "session_frames": 100,
        "seed": 7,
        "blink_filter": {"fill": "joint"},
        "smoothing": {"sigma_s": 0.2},
        "render": {"natural_blinks": True, "width": out_size[0], "height": out_size[1]},
        "classes": {
            "reading": {
                "sessions": 2,
                "sources": [
                    {
                        "format": "fixations",
                        "path": str(DATA / "onestop_fixations.csv"),
                        "group_columns": ["participant_id", "TRIAL_INDEX"],
                        "amplitude_column": "NEXT_SAC_AMPLITUDE",
                        "screen_px": [2560, 1440],
                    }
                ],
            },
            "conversation": {
                "sessions": 2,
                "sources": [{"format": "video", "path": str(DATA / "franck.mp4")}],
            },
        },
    }


def to_toml(d: dict, prefix: str = "") -> str:
    """A config dict as TOML text, written independently of the package
    (the package converts dicts in Rust), for the CLI side of comparisons."""

    def val(v):
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, (int, float)):
            return repr(v)
        if isinstance(v, str):
            return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
        if isinstance(v, list):
            return "[" + ", ".join(val(x) for x in v) + "]"
        if isinstance(v, dict):
            return "{ " + ", ".join(f"{k} = {val(x)}" for k, x in v.items()) + " }"
        raise TypeError(type(v))

    lines, tables = [], []
    for k, v in d.items():
        if isinstance(v, dict):
            tables.append((k, v))
        else:
            lines.append(f"{k} = {val(v)}")
    text = "\n".join(lines) + "\n"
    for k, v in tables:
        name = f"{prefix}{k}"
        text += f"\n[{name}]\n" + to_toml(v, name + ".")
    return text


@pytest.fixture(scope="session")
def cache_dir():
    return os.environ.get("EYEREPLAY_CACHE", str(ROOT / ".cache"))
