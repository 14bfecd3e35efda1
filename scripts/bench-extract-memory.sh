#!/usr/bin/env bash
# Peak memory of `eyereplay extract` on a one-hour 1080p video: franck.mp4
# (200 s) looped 18 times and upscaled to 1920x1080 (made once, cached in
# .cache/bench/), then extracted under /usr/bin/time -v. The limit is 400 MB.
#   scripts/bench-extract-memory.sh [EXTRACT_FLAG...]   (after scripts/setup.sh and a release build)
# Flags go to `eyereplay extract`, e.g. `--landmarks cascade` (the default is the attention mesh).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
video="$root/.cache/bench/hour1080.mp4"
bin="${EYEREPLAY_BIN:-$root/target/release/eyereplay}"
mkdir -p "$(dirname "$video")"
if [[ ! -f "$video" ]]; then
  echo "bench: making a one-hour 1080p video (about 8 min)"
  ffmpeg -hide_banner -loglevel error -y -stream_loop 17 -i "$root/.cache/data/franck.mp4" \
    -vf scale=1920:1080 -c:v libx264 -preset ultrafast -crf 32 -an "$video.part.mp4"
  mv "$video.part.mp4" "$video"
fi
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
/usr/bin/time -v "$bin" extract "$video" --out "$out/hour.csv" -q "$@" 2>"$out/time.txt"
rss_kb=$(awk -F: '/Maximum resident set size/ {gsub(/ /, "", $2); print $2}' "$out/time.txt")
wall=$(awk -F': ' '/Elapsed \(wall clock\)/ {print $2}' "$out/time.txt")
echo "one-hour 1080p video${*:+ ($*)}: peak RSS $((rss_kb / 1024)) MiB (limit 400 MB) = $(awk -v r="$rss_kb" 'BEGIN {printf "%.2f", r * 1024 / 400e6}') x the limit; wall time $wall"
