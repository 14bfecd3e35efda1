#!/usr/bin/env bash
# The main job: a small labeled dataset from the bundled real recordings
# (examples/default.toml), with its evaluation report.
#
#   scripts/run.sh [OUT]          default OUT: out/default
#
# Installs what it needs first (scripts/setup.sh; skips what is in place),
# builds eyereplay in release mode, then runs 'eyereplay generate'. Rerunning
# resumes: finished sessions are verified and skipped.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
out="${1:-out/default}"
"$root/scripts/setup.sh"
echo "run: cargo build --release"
cargo build --release --quiet -p eyereplay-cli
export EYEREPLAY_CACHE="${EYEREPLAY_CACHE:-$root/.cache}"
# The report reads one session of each class back whole with the extractor
# and tabulates it (--read-back N for more, --read-back-all for every one:
# about two and a half minutes more here; docs/PERFORMANCE.md).
"$root/target/release/eyereplay" generate --config examples/default.toml --out "$out"
# The default reading detector (docs/DETECTOR.md): trained on what the
# extractor reads from generated readers and talkers drawn as whole faces
# (examples/detector/train_behaviour_face.toml: 32 people, 30 s each; about
# 7 minutes the first time, skipped once rendered), 10 s windows, 100
# bagged decision trees, its probabilities calibrated and its threshold set
# for 5 % false positives.
# Detect your own video, or find when someone reads in an interview, with
#   target/release/eyereplay detect VIDEO --model out/default/detector.json
train="${out%/}-detector-train"
"$root/target/release/eyereplay" generate --config examples/detector/train_behaviour_face.toml --out "$train" --no-evaluate
"$root/target/release/eyereplay" train "$train" --out "$out/detector.json"
