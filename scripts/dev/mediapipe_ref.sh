#!/usr/bin/env bash
# Runs the MediaPipe Python reference (creating its venv first if needed).
#   scripts/dev/mediapipe_ref.sh VIDEO [OUT.csv]
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
cache="${EYEREPLAY_CACHE:-$here/../../.cache}"
"$here/mediapipe-venv.sh" >&2
exec "$cache/venv-mediapipe/bin/python" "$here/mediapipe_ref.py" "$@"
