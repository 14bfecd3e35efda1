#!/usr/bin/env bash
# Compares two builds of `eyereplay extract` on one video, as the closing
# notes' "before / after" rows were measured: whole processes, alternating
# A B A B on the same machine, printing each run's CPU time per frame
# (user + sys) and wall time, then how far the last runs' rows are apart
# (scripts/dev/rows_diff.py).
#
#   scripts/dev/ab-extract.sh OLD_BIN VIDEO [ROUNDS] [-- EXTRACT_ARGS...]
#
# OLD_BIN: an `eyereplay` binary built from another revision (for example
# `git worktree add /tmp/old REV && cargo build --release` there). The new
# side is target/release/eyereplay (or $EYEREPLAY_BIN). ROUNDS defaults to
# 3; EXTRACT_ARGS go to both (for example `--max-seconds 1200`).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
usage="usage: ab-extract.sh OLD_BIN VIDEO [ROUNDS] [-- EXTRACT_ARGS...]"
old="${1:?$usage}"
video="${2:?$usage}"
shift 2
rounds=3
if [[ $# -gt 0 && "$1" != "--" ]]; then rounds="$1"; shift; fi
[[ $# -gt 0 && "$1" == "--" ]] && shift
new="${EYEREPLAY_BIN:-$root/target/release/eyereplay}"
for b in "$old" "$new"; do
  [[ -x "$b" ]] || { echo "ab-extract: $b: no such executable" >&2; exit 1; }
done
[[ -f "$video" ]] || { echo "ab-extract: $video: no such file" >&2; exit 1; }
[[ "$rounds" =~ ^[1-9][0-9]*$ ]] || { echo "ab-extract: ROUNDS must be a positive integer, not $rounds" >&2; exit 1; }
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
for r in $(seq "$rounds"); do
  for side in old new; do
    bin=$old; [[ $side == new ]] && bin=$new
    /usr/bin/time -f "%U %S %e" -o "$out/time" "$bin" extract "$video" --out "$out/$side.csv" \
      --quiet "$@" >"$out/log" 2>&1 || { cat "$out/log" >&2; exit 1; }
    read -r user sys wall <"$out/time"
    frames=$(($(wc -l <"$out/$side.csv") - 1))
    python3 -c "import sys; u, s, w, n = map(float, sys.argv[1:]); \
print(f'round $r $side: {(u + s) * 1000 / n:.3f} CPU-ms per frame ({int(n)} frames), wall {w:.1f} s')" \
      "$user" "$sys" "$wall" "$frames"
  done
done
python3 "$root/scripts/dev/rows_diff.py" "$out/old.csv" "$out/new.csv"
