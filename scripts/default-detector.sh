#!/usr/bin/env bash
# The default reading detector the Python wheel ships: runs the main job
# (scripts/run.sh, which generates the bundled default dataset, then the
# detector's training video from examples/detector/train_behaviour_face.toml,
# and trains out/default/detector.json on it) and copies that model into the package,
# crates/eyereplay-py/python/eyereplay/default_detector.json. Training is
# deterministic: the same checkout gives the same file byte for byte.
#
#   scripts/default-detector.sh
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
"$root/scripts/run.sh" out/default
cp out/default/detector.json crates/eyereplay-py/python/eyereplay/default_detector.json
echo "default-detector: crates/eyereplay-py/python/eyereplay/default_detector.json updated"
