#!/usr/bin/env bash
# Builds the Python package `eyereplay` (crates/eyereplay-py) into an abi3
# wheel with maturin, for CPython 3.9 and later on this Linux.
#
#   scripts/python-wheel.sh [--profile dev|release]     default: release
#
# maturin comes from the package registry through pip, pinned by version and
# sha256 (crates/eyereplay-py/requirements-build.txt), into a venv in the
# cache; the wheel goes to target/wheels/. `pip install target/wheels/eyereplay-*.whl`
# is then all a user needs (plus the ffmpeg program and the models, as for
# the command line: eyereplay.fetch_models()).
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
rm -f target/wheels/eyereplay-*.whl
echo "python-wheel: maturin build --profile $profile"
# --compatibility linux: the extension links Debian's libav* (decoding with
# exact timestamps), which manylinux's library policy does not allow
# unbundled; see the README's Python section.
"$venv/bin/maturin" build --quiet --profile "$profile" --compatibility linux \
  --interpreter "$py" -m crates/eyereplay-py/Cargo.toml -o target/wheels
ls target/wheels/eyereplay-*.whl
