#!/usr/bin/env bash
# Checks extraction's CUDA path against the CPU on a machine with an NVIDIA
# GPU: the same video with --device cpu and --device cuda, 1 and 2 workers,
# printing wall time, CPU time per frame by stage, peak memory, and how far
# the CUDA rows are from the CPU's (open-eye frames).
#
#   scripts/dev/cuda-check.sh ORT_GPU_LIB [VIDEO]
#
# EYEREPLAY_CUDA_CHECK_WORKERS lists the worker counts (default "2 1"; the
# docs/EXTRACTION.md's table also has 8), EYEREPLAY_CUDA_CHECK_LANDMARKS the
# networks (default "attention cascade": `extract`'s default, then the
# cascade that reads rendered video back).
#
# ORT_GPU_LIB: the libonnxruntime.so.<version> of an onnxruntime-gpu install
# (for example `pip install onnxruntime-gpu==1.31.1`, built for CUDA 13: its
# onnxruntime/capi/ folder), with the CUDA and cuDNN libraries it needs on
# LD_LIBRARY_PATH. VIDEO defaults to the bundled .cache/data/franck.mp4.
# The binary is target/release/eyereplay (cargo build --release).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
lib="${1:?usage: cuda-check.sh ORT_GPU_LIB [VIDEO]}"
video="${2:-$root/.cache/data/franck.mp4}"
bin="${EYEREPLAY_BIN:-$root/target/release/eyereplay}"
[[ -f "$lib" ]] || { echo "cuda-check: $lib: no such file" >&2; exit 1; }
[[ -f "$video" ]] || { echo "cuda-check: $video: no such file" >&2; exit 1; }
[[ -x "$bin" ]] || { echo "cuda-check: $bin: not built (cargo build --release)" >&2; exit 1; }
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
run() { # name landmarks threads device [env...]
  local name=$1 landmarks=$2 threads=$3 device=$4
  shift 4
  local t0 t1
  t0=$(date +%s.%N)
  "$@" "$bin" extract "$video" --out "$out/$name.csv" --device "$device" --threads "$threads" \
    --landmarks "$landmarks" --profile --quiet >"$out/$name.log" 2>&1 || { cat "$out/$name.log"; exit 1; }
  t1=$(date +%s.%N)
  echo "== $name: wall $(python3 -c "print(round($t1 - $t0, 2))") s"
  grep -E "networks on|WARN|network|total|peak RSS" "$out/$name.log"
}
gpu=(env "EYEREPLAY_ORT_LIB=$lib")
workers="${EYEREPLAY_CUDA_CHECK_WORKERS:-2 1}"
models="${EYEREPLAY_CUDA_CHECK_LANDMARKS:-attention cascade}"
for m in $models; do
  for n in $workers; do
    run "${m}_cpu_t$n" "$m" "$n" cpu env
    run "${m}_cuda_t$n" "$m" "$n" cuda "${gpu[@]}"
  done
  for n in $workers; do
    echo "== $m, $n workers: CUDA rows against the CPU's"
    python3 "$root/scripts/dev/rows_diff.py" "$out/${m}_cpu_t$n.csv" "$out/${m}_cuda_t$n.csv"
  done
done
