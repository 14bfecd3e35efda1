#!/usr/bin/env bash
# Regenerates crates/eyereplay-eval/tests/data/pymovements_events.json, the
# fixations and saccades pymovements finds in two sessions of the bundled
# default, which eyereplay-eval's I-VT events are checked against
# (tests/pymovements_events.rs). Makes its own venv in .cache/ with
# pymovements pinned, installed by pip. The sessions come from a dataset made
# by `eyereplay generate --out out/default` (the default config). Run from
# anywhere:
#   bash scripts/dev/pymovements_reference.sh [DATASET]
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
dataset="${1:-$root/out/default}"
for s in reading/reading_0000.csv conversation/conversation_0000.csv; do
    if [[ ! -f "$dataset/$s" ]]; then
        echo "pymovements_reference: $dataset/$s: no such session; run 'eyereplay generate --out $dataset' first" >&2
        exit 1
    fi
done
venv="$root/.cache/pymovements-reference-venv"
if [[ ! -x "$venv/bin/python" ]]; then
    python3 -m venv "$venv"
fi
"$venv/bin/pip" install --quiet --disable-pip-version-check \
    "pymovements==0.28.0" "numpy==2.4.6" "polars==2.1.0"
"$venv/bin/python" "$root/scripts/dev/pymovements_reference.py" \
    "$root/crates/eyereplay-eval/tests/data/pymovements_events.json" \
    "$dataset/reading/reading_0000.csv" "$dataset/conversation/conversation_0000.csv"
