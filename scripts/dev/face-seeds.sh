#!/usr/bin/env bash
# The bundled default at several seeds, each generated and read back, then
# one pooled comparison: one run moves single sessions' read-back r by
# about 0.01, so a change to the full-face renderer is judged over seeds.
#
#   scripts/dev/face-seeds.sh [--views V] [--probe-only] OUT_ROOT SEED [SEED ...]
#
# Writes OUT_ROOT/seedN.toml (examples/default.toml with `seed = N` and its
# relative paths made absolute; with --views V, `extractor_iris_views = V`:
# 1 gives the one-crop probe and read-back of earlier versions; with
# --probe-only, `match_readback = false`: each session drawn through its
# probe's match alone, as before the read-back match) and the dataset OUT_ROOT/seedN (complete
# sessions of an earlier run are kept) with its evaluation reading every
# session back (`--read-back-all`), then runs
# `cargo xtask face-table OUT_ROOT/seed... --horizontal --vertical`, whose
# last lines are the pooled means. Needs scripts/setup.sh's data and a
# release build (scripts/run.sh does both).
set -euo pipefail
views=""
if [ "${1:-}" = "--views" ]; then
  views=${2:-}
  case $views in [1-9]) ;; *) echo "face-seeds: --views takes 1 to 9, not '$views'" >&2; exit 2;; esac
  shift 2
fi
readback=""
if [ "${1:-}" = "--probe-only" ]; then
  readback=false
  shift
fi
if [ $# -lt 2 ]; then
  echo "usage: $0 [--views V] [--probe-only] OUT_ROOT SEED [SEED ...]" >&2
  exit 2
fi
repo=$(cd "$(dirname "$0")/../.." && pwd)
bin="$repo/target/release/eyereplay"
[ -x "$bin" ] || { echo "face-seeds: $bin: not built (run scripts/run.sh or cargo build --release)" >&2; exit 1; }
root=$1; shift
mkdir -p "$root"
# Every seed checked before hours of work start.
for seed in "$@"; do
  case $seed in ''|*[!0-9]*) echo "face-seeds: seed '$seed' is not a whole number" >&2; exit 2;; esac
done
dirs=()
for seed in "$@"; do
  cfg="$root/seed$seed.toml"
  sed -e "s/^seed = .*/seed = $seed/" -e "s|\"\\.\\./|\"$repo/|g" \
    ${views:+-e "s/^extractor_iris_views = .*/extractor_iris_views = $views/"} \
    ${readback:+-e "s/^match_readback = .*/match_readback = $readback/"} \
    "$repo/examples/default.toml" > "$cfg.part"
  mv "$cfg.part" "$cfg"
  out="$root/seed$seed"
  # generate resumes: complete sessions are skipped, a half folder finished.
  "$bin" generate --config "$cfg" --out "$out" --read-back-all
  dirs+=("$out")
done
cargo run --quiet --manifest-path "$repo/Cargo.toml" -p xtask -- face-table "${dirs[@]}" --horizontal --vertical
