#!/usr/bin/env bash
# Creates the venv for the MediaPipe Python reference (dev only):
# .cache/venv-mediapipe with mediapipe==0.10.21 (the same wheel whose models
# eyereplay uses, sha256-pinned by scripts/models.sh) and the few runtime
# packages its face mesh needs, pinned. jax, sentencepiece and sounddevice are
# declared by the wheel but not used by the face mesh, so they are skipped.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
cache="${EYEREPLAY_CACHE:-$root/.cache}"
venv="$cache/venv-mediapipe"
if "$venv/bin/python" -c 'import mediapipe, cv2' 2>/dev/null; then
  echo "mediapipe-venv: have $venv"
  exit 0
fi
"$root/scripts/models.sh" >/dev/null # fetches and verifies the mediapipe wheel
python3 -m venv "$venv"
"$venv/bin/pip" install --quiet --no-deps "$cache/pip/mediapipe-0.10.21-cp311-cp311-manylinux_2_28_x86_64.whl"
"$venv/bin/pip" install --quiet numpy==1.26.4 protobuf==4.25.8 absl-py==2.1.0 attrs==24.3.0 \
  flatbuffers==24.12.23 opencv-python-headless==4.10.0.84 matplotlib==3.9.4
echo "mediapipe-venv: created $venv"
