#!/usr/bin/env bash
# Does extraction read every common pixel format and codec as it reads
# 8-bit 4:2:0 H.264? Makes 6-s copies of franck.mp4 in each (ffmpeg with
# its usual encoders), extracts each with the default, and prints how far
# its rows are from the H.264 copy's (scripts/dev/rows_diff.py). Two
# encodings of one video differ by the encoders' own loss, so compare the
# lines with each other, not with zero. docs/EXTRACTION.md, "Formats".
#
#   scripts/dev/formats-check.sh [SCRATCH_DIR]
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
export EYEREPLAY_CACHE=${EYEREPLAY_CACHE:-$root/.cache}
src=$EYEREPLAY_CACHE/data/franck.mp4
[ -f "$src" ] || { echo "error: $src: missing; run scripts/setup.sh" >&2; exit 1; }
bin=$root/target/release/eyereplay
[ -x "$bin" ] || cargo build --release -q -p eyereplay-cli --manifest-path "$root/Cargo.toml"
dir=${1:-$(mktemp -d)}
mkdir -p "$dir"
enc() { ffmpeg -v error -y -t 6 -i "$src" -an "$@"; }
enc -c:v libx264 -pix_fmt yuv420p -crf 18 "$dir/h264.mp4"
declare -A what=(
  [p10.mp4]="H.264 10-bit 4:2:0" [p422.mp4]="H.264 4:2:2" [p444.mp4]="H.264 4:4:4"
  [hevc.mp4]="HEVC (x265)" [vp9.webm]="VP9 in WebM" [av1.mkv]="AV1 (libaom) in Matroska"
  [mjpeg.avi]="Motion JPEG in AVI" [prores.mov]="ProRes 422 in QuickTime" [mpeg4.mp4]="MPEG-4 Part 2"
  [ffv1.mkv]="FFV1 RGB (lossless)" [raw.avi]="raw BGR in AVI" [gray.mp4]="H.264 grayscale"
  [gray420.mp4]="H.264 4:2:0 of the grayscale picture")
enc -c:v libx264 -pix_fmt yuv420p10le -crf 18 "$dir/p10.mp4"
enc -c:v libx264 -pix_fmt yuv422p -crf 18 "$dir/p422.mp4"
enc -c:v libx264 -pix_fmt yuv444p -crf 18 "$dir/p444.mp4"
enc -c:v libx265 -crf 20 -x265-params log-level=error "$dir/hevc.mp4"
enc -c:v libvpx-vp9 -b:v 1M "$dir/vp9.webm"
enc -c:v libaom-av1 -cpu-used 8 -crf 30 "$dir/av1.mkv"
enc -c:v mjpeg -q:v 3 "$dir/mjpeg.avi"
enc -c:v prores_ks "$dir/prores.mov"
enc -c:v mpeg4 -q:v 3 "$dir/mpeg4.mp4"
enc -c:v ffv1 -pix_fmt rgb24 "$dir/ffv1.mkv"
enc -c:v rawvideo -pix_fmt bgr24 "$dir/raw.avi"
enc -c:v libx264 -pix_fmt gray -crf 18 "$dir/gray.mp4"
enc -vf "format=gray,format=yuv420p" -c:v libx264 -crf 18 "$dir/gray420.mp4"
"$bin" extract "$dir/h264.mp4" --out "$dir/h264.csv" --quiet >/dev/null
for f in p10.mp4 p422.mp4 p444.mp4 hevc.mp4 vp9.webm av1.mkv mjpeg.avi prores.mov mpeg4.mp4 \
  ffv1.mkv raw.avi gray.mp4 gray420.mp4; do
  "$bin" extract "$dir/$f" --out "$dir/$f.csv" --quiet >/dev/null
  printf '%-40s ' "${what[$f]}:"
  python3 "$root/scripts/dev/rows_diff.py" "$dir/h264.csv" "$dir/$f.csv"
done
echo "gray, against the grayscale picture in 4:2:0:"
python3 "$root/scripts/dev/rows_diff.py" "$dir/gray420.mp4.csv" "$dir/gray.mp4.csv"
# Variable frame rate: of every ten frames the 4th to 6th dropped. Its rows
# keep each frame's own time; compared with the H.264 copy's at the times
# both have.
enc -vf "select='not(between(mod(n\,10)\,3\,5))'" -fps_mode vfr -c:v libx264 -crf 18 "$dir/vfr.mkv"
"$bin" extract "$dir/vfr.mkv" --out "$dir/vfr.mkv.csv" --quiet >/dev/null
python3 - "$dir/h264.csv" "$dir/vfr.mkv.csv" <<'PY'
import csv, sys
base, vfr = ({round(float(r["time_s"]), 3): r for r in csv.DictReader(open(f))} for f in sys.argv[1:])
d = sorted(abs(float(vfr[t]["nx"]) - float(base[t]["nx"]))
           for t in vfr if t in base and vfr[t]["valid"] == "1" and base[t]["valid"] == "1")
times = sorted(vfr)[:4]
print(f"variable frame rate: {len(vfr)} rows, first times {times}; at the {len(d)} common "
      f"valid times nx |d| median {d[len(d) // 2]:.1e}")
PY
