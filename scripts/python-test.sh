#!/usr/bin/env bash
# The Python package's tests: builds the wheel (scripts/python-wheel.sh),
# installs it into a fresh venv with numpy, pandas and pytest (pinned by
# version and sha256: crates/eyereplay-py/requirements-test.txt), and runs
# pytest on crates/eyereplay-py/tests, which compare the package with the
# `eyereplay` binary on the bundled sample data.
#
#   scripts/python-test.sh [--profile dev|release] [PYTEST ARGS]   default: release
#
# Needs scripts/setup.sh done (sample data, models). scripts/test.sh calls
# this with --profile dev, after `cargo test` has built target/debug/eyereplay.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
profile=release
if [[ "${1:-}" == "--profile" ]]; then
  profile="${2:?--profile needs dev or release}"
  shift 2
fi
dir=release
[[ "$profile" == dev ]] && dir=debug
export EYEREPLAY_CACHE="${EYEREPLAY_CACHE:-$root/.cache}"
py="${PYTHON:-python3}"

echo "python-test: cargo build --profile $profile -p eyereplay-cli"
# The wheel's build reuses the workspace build's compiled crates only where
# both resolve a crate with the same features (eyereplay-py's Cargo.toml).
rc=0
differ=$("$py" "$root/scripts/dev/wheel_features.py") || rc=$?
if [[ $rc -eq 1 ]]; then
  echo "python-test: note: the wheel's build compiles these crates again, with other features than the workspace's (add them to crates/eyereplay-py/Cargo.toml):"
  echo "$differ"
fi
cargo build --quiet --profile "$profile" -p eyereplay-cli
bash "$root/scripts/python-wheel.sh" --profile "$profile"

venv="$root/target/py-test-venv"
req="$root/crates/eyereplay-py/requirements-test.txt"
echo "python-test: fresh venv $venv"
rm -rf "$venv"
"$py" -m venv "$venv"
"$venv/bin/pip" download --quiet --require-hashes -r "$req" -d "$EYEREPLAY_CACHE/pip"
"$venv/bin/pip" install --quiet --no-index --find-links "$EYEREPLAY_CACHE/pip" --require-hashes -r "$req"
"$venv/bin/pip" install --quiet --no-index --no-deps target/wheels/eyereplay-*.whl

echo "python-test: pytest"
# From the tests' folder, so `import eyereplay` is the installed wheel, not
# the source tree.
cd "$root/crates/eyereplay-py/tests"
EYEREPLAY_BIN="$root/target/$dir/eyereplay" EYEREPLAY_ROOT="$root" \
  "$venv/bin/python" -m pytest -q -p no:cacheprovider "$@" .

echo "python-test: the wheel alone (fresh venv, empty folder, fresh HOME, no checkout)"
# pip resolves the wheel's declared dependencies (numpy) as it would from
# the package registry, here from a wheelhouse holding only what it needs;
# the check runs with no EYEREPLAY_* variable and a HOME of its own, so the
# checkout's .cache is out of reach.
alone="$(mktemp -d)"
trap 'rm -rf "$alone"' EXIT
mkdir -p "$alone/wheels" "$alone/home" "$alone/work"
cp "$EYEREPLAY_CACHE"/pip/numpy-1.26.4-*.whl "$root"/target/wheels/eyereplay-*.whl "$alone/wheels/"
"$py" -m venv "$alone/venv"
"$alone/venv/bin/pip" install --quiet --no-index --find-links "$alone/wheels" eyereplay
ls -l "$root"/target/wheels/eyereplay-*.whl | awk '{printf "python-test: wheel size %.1f MB\n", $5 / 1e6}'
# 12 s of a real talking face, its frames as raw RGB, and the command
# line's CSV of it to compare with.
ffmpeg -loglevel error -y -i "$EYEREPLAY_CACHE/data/franck.mp4" -t 12 -c:v libx264 -preset veryfast \
  -an "$alone/clip.mp4"
ffmpeg -loglevel error -y -i "$alone/clip.mp4" -f rawvideo -pix_fmt rgb24 "$alone/frames.rgb"
"$root/target/$dir/eyereplay" extract "$alone/clip.mp4" --out "$alone/want.csv" > /dev/null
size=$(ffprobe -v error -select_streams v:0 -show_entries stream=width,height -of csv=p=0 "$alone/clip.mp4")
cp "$root/crates/eyereplay-py/tests/standalone/check.py" "$alone/check.py"
cd "$alone/work"
env -i HOME="$alone/home" PATH=/usr/local/bin:/usr/bin:/bin "$alone/venv/bin/python" "$alone/check.py" \
  "$alone/clip.mp4" "$alone/frames.rgb" "$alone/want.csv" "${size%,*}" "${size#*,}"
echo "python-test: the wheel alone: ok"
