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
# The package is self-contained: MediaPipe's networks (converted, Apache-2.0)
# and the pinned ONNX Runtime library (MIT, from the onnxruntime wheel that
# scripts/models.sh unpacks) go inside it with their licenses and NOTICE,
# and so does the default reading detector. Copied in for the build only
# (git-ignored): the repository itself holds no weights.
pkg="$root/crates/eyereplay-py/python/eyereplay"
rm -rf "$pkg/models"
mkdir -p "$pkg/models"
# The .tflite sources too: `check_models` verifies their pinned sha256 (and
# each network against the sha256 its conversion recorded, the .src stamps), and
# metadata.json lists every model file's sha256, so the package writes the
# same provenance (and the same bytes) as the command line.
for f in face_detection_short_range.onnx face_landmark.onnx iris_landmark.onnx \
    face_landmark_with_attention.onnx face_landmark_with_attention_eyes.onnx \
    face_detection_short_range.tflite face_landmark.tflite iris_landmark.tflite \
    face_landmark_with_attention.tflite \
    face_detection_short_range.onnx.src face_landmark.onnx.src iris_landmark.onnx.src \
    face_landmark_with_attention.onnx.src \
    libonnxruntime.so.1.22.1 LICENSE-mediapipe LICENSE-onnxruntime ThirdPartyNotices-onnxruntime.txt; do
  [[ -f "$cache/models/$f" ]] || { echo "python-wheel: $cache/models/$f missing: run scripts/setup.sh" >&2; exit 1; }
  cp "$cache/models/$f" "$pkg/models/$f"
done
cp "$root/NOTICE" "$pkg/models/NOTICE"
# The full-face mode's canonical mesh (MediaPipe's, Apache-2.0) and bundled
# photos with their licenses (scripts/face-assets.sh; 1.3 MB), so whole
# faces render from the wheel alone too.
rm -rf "$pkg/faces"
mkdir -p "$pkg/faces"
[[ -f "$cache/faces/canonical_face_mesh.binarypb" ]] || { echo "python-wheel: $cache/faces missing: run scripts/setup.sh" >&2; exit 1; }
cp "$cache/faces/"* "$pkg/faces/"
cp "$root/NOTICE" "$pkg/faces/NOTICE"
rm -f target/wheels/eyereplay-*.whl
echo "python-wheel: maturin build --profile $profile"
# manylinux_2_35: the extension links only glibc (2.35 or later: Ubuntu
# 22.04, Debian 12 and newer), libgcc_s and libm; maturin checks it against
# the policy (auditwheel) before tagging.
"$venv/bin/maturin" build --quiet --strip --profile "$profile" --compatibility manylinux_2_35 \
  --interpreter "$py" -m crates/eyereplay-py/Cargo.toml -o target/wheels
ls target/wheels/eyereplay-*.whl
