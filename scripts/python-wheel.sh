#!/usr/bin/env bash
# Builds the Python package `eyereplay` (crates/eyereplay-py) into an abi3
# manylinux wheel with maturin, for CPython 3.9 and later on x86-64 Linux
# with glibc 2.35 or later, FFmpeg linked in statically (scripts/ffmpeg-static.sh).
#
#   scripts/python-wheel.sh [--profile dev|release]     default: release
#
# maturin comes from the package registry through pip, pinned by version and
# sha256 (crates/eyereplay-py/requirements-build.txt), into a venv in the
# cache; the wheel goes to target/wheels/. `pip install target/wheels/eyereplay-*.whl`
# is then all a user needs for extraction and datasets (plus the models,
# scripts/models.sh DIR; rendering MP4s runs the ffmpeg program, as the
# command line does, so that x264 stays in its own process).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
profile=release
[[ "${1:-}" == "--profile" ]] && profile="${2:?--profile needs dev or release}"
cache="${EYEREPLAY_CACHE:-$root/.cache}"
py="${PYTHON:-python3}"
venv="$cache/venv-maturin"
req="$root/crates/eyereplay-py/requirements-build.txt"
if ! "$venv/bin/maturin" --version 2>/dev/null | grep -q "maturin 1.9.6"; then
  echo "python-wheel: installing maturin 1.9.6 into $venv (pinned sha256)"
  "$py" -m venv "$venv"
  "$venv/bin/pip" download --quiet --require-hashes -r "$req" -d "$cache/pip"
  "$venv/bin/pip" install --quiet --no-index --find-links "$cache/pip" --require-hashes -r "$req"
else
  echo "python-wheel: maturin 1.9.6 present"
fi
# FFmpeg linked statically (decoders only), so the wheel needs no libav*.
bash "$root/scripts/ffmpeg-static.sh"
# The shared build behind the link (scripts/ffmpeg-static.sh).
export FFMPEG_DIR="$(readlink -f "$cache/ffmpeg-static")"
rm -f target/wheels/eyereplay-*.whl
echo "python-wheel: maturin build --profile $profile"
# manylinux_2_35: the extension links only glibc (2.35 or later: Ubuntu
# 22.04, Debian 12 and newer), libgcc_s and libm; maturin checks it against
# the policy (auditwheel) before tagging.
"$venv/bin/maturin" build --quiet --strip --profile "$profile" --compatibility manylinux_2_35 \
  --interpreter "$py" -m crates/eyereplay-py/Cargo.toml -o target/wheels
ls target/wheels/eyereplay-*.whl
