#!/usr/bin/env python3
"""Shared dependencies that the wheel's build would compile with other
features than `cargo test --workspace` does.

    python3 scripts/dev/wheel_features.py        # prints them; exit 1 if any, 2 if cargo tree fails

`scripts/test.sh` builds the workspace's tests, then the Python wheel
(crates/eyereplay-py, through maturin) into the same target folder. Cargo
reuses a compiled crate only when its features are the same in both builds;
the workspace build unifies the features every member and dev-dependency
asks for, the wheel's build only those under eyereplay-py. One differing
leaf (say `either` without `use_std`) changes the hash of every crate above
it, and the wheel's build then compiles most of the dependency tree again
(about 4 minutes of CI). eyereplay-py's Cargo.toml asks for the missing
features; this lists any that a dependency change brings back. The wheel's
own differences (FFmpeg linked statically, pyo3's extension-module) are
expected and not listed.
"""
import re, subprocess, sys

EXPECTED = {"eyereplay-extract", "eyereplay-py", "ffmpeg-next", "ffmpeg-sys-next",
            "pyo3", "pyo3-build-config", "pyo3-ffi"}


def tree(args):
    out = subprocess.run(["cargo", "tree", *args, "-f", "{p} [{f}]", "--prefix", "none"],
                         check=True, capture_output=True, text=True).stdout
    sets = {}
    for line in out.splitlines():
        m = re.match(r"(\S+) (v\S+).*?\[(.*)\]", line)
        if m:
            sets.setdefault((m.group(1), m.group(2)), set()).add(m.group(3))
    return sets


def main():
    try:
        ws = tree(["--workspace", "-e", "normal,build,dev"])
        py = tree(["-p", "eyereplay-py", "--features", "pyo3/extension-module,static-ffmpeg",
                   "-e", "normal,build"])
    except (OSError, subprocess.CalledProcessError) as e:
        # Cannot tell: not a drift (exit 1 means one).
        detail = (getattr(e, "stderr", None) or str(e)).strip().splitlines()
        print(f"wheel_features: cargo tree failed: {detail[-1] if detail else e}", file=sys.stderr)
        return 2
    differ = []
    for key, feats in sorted(py.items()):
        if key[0] in EXPECTED or key not in ws:
            continue
        # A crate used both as a build dependency and a normal one has two
        # sets in the workspace: the wheel's must be among them.
        if not feats <= ws[key]:
            differ.append(f"{key[0]} {key[1]}: workspace {sorted(ws[key])}, wheel {sorted(feats)}")
    for d in differ:
        print(d)
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())
