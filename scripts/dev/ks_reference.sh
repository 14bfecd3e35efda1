#!/usr/bin/env bash
# Regenerates crates/eyereplay-eval/tests/data/ks_scipy.json, the reference
# values the Rust two-sample KS test is checked against. Makes its own venv in
# .cache/ with scipy pinned, installed by pip. Run from anywhere:
#   bash scripts/dev/ks_reference.sh
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
venv="$root/.cache/ks-reference-venv"
if [[ ! -x "$venv/bin/python" ]]; then
    python3 -m venv "$venv"
fi
"$venv/bin/pip" install --quiet --disable-pip-version-check \
    "numpy==2.3.5" "scipy==1.17.1"
"$venv/bin/python" "$root/scripts/dev/ks_reference.py" \
    "$root/crates/eyereplay-eval/tests/data/ks_scipy.json"
