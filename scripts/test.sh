#!/usr/bin/env bash
# The test command: installs what the tests need (scripts/setup.sh), then runs
# formatting and lint checks, every test of the workspace, the Python
# package's tests (scripts/python-test.sh) and the cluster test. Real sample data
# and models are required (CI=1 turns a missing cache into a failure).
#
#   scripts/test.sh
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
# Each phase's wall time, so a slow CI run shows where the time went.
phase_start=$SECONDS
phase() {
  echo "test: $1   [previous step: $((SECONDS - phase_start)) s]"
  phase_start=$SECONDS
}
"$root/scripts/setup.sh"
export CI="${CI:-1}"
# A fresh clone (CI) builds each crate once: cargo's incremental caches
# would only add disk and compile time for rebuilds that never come (2.2 of
# the 7.5 GB a fresh clone's target/ held, 30 Nov 2026). A checkout that
# already has them, a developer's, keeps them.
if [[ -z "${CARGO_INCREMENTAL:-}" && ! -d target/debug/incremental ]]; then
  export CARGO_INCREMENTAL=0
fi
# The build and the tests' outputs need about 6 GB; say so before the
# linker runs out of room halfway through.
free_kib=$(df -Pk "$root" | awk 'NR == 2 {print $4}')
if [[ -n "$free_kib" && "$free_kib" -lt $((6 * 1024 * 1024)) ]]; then
  echo "test: warning: only $((free_kib / 1024)) MiB free on the disk of $root; a fresh build and the tests need about 6 GiB" >&2
fi
phase "setup done; cargo fmt --check"
cargo fmt --all -- --check
# Module import cycles are checked by a test of the xtask's
# (`the_workspace_has_no_module_cycles`, in `cargo test` below): run on its
# own, `cargo xtask cycles` built the xtask's dependencies once more with
# their own features, about 2 minutes from a fresh clone.
#
# Clippy's lints (-D warnings) run inside the test build, not in a
# `cargo clippy` of their own: clippy-driver, as cargo's wrapper for the
# workspace's crates, compiles them in full and lints them as `cargo clippy`
# would, so the dependencies are compiled once instead of once checked for
# clippy and once built for the tests (a fresh clone on 2 cores: the build
# with the lints took as long as the plain one, where `cargo clippy` had
# cost about 5 minutes more; docs/STRUCTURE.md, "Tests"). Exported, so that
# the wheel's build below reuses the crates that do not link FFmpeg rather
# than compiling them again without the wrapper.
clippy_driver="$(rustc --print sysroot)/bin/clippy-driver"
[[ -x "$clippy_driver" ]] || clippy_driver="$(command -v clippy-driver || true)"
[[ -n "$clippy_driver" && -x "$clippy_driver" ]] || { echo "test: clippy-driver not found in the toolchain ($(rustc --print sysroot)/bin) or on PATH: rustup component add clippy" >&2; exit 1; }
export RUSTC_WORKSPACE_WRAPPER="$clippy_driver"
export CLIPPY_ARGS="-D__CLIPPY_HACKERY__warnings__CLIPPY_HACKERY__"
phase "cargo test: build every target, clippy's lints included (-D warnings)"
# Not --all-targets: that builds the examples with the test harness, and
# `cargo test` below then builds them again as the plain programs they are
# (about a minute). Here everything else; the examples there, linted alike.
cargo test --workspace --lib --bins --tests --benches --no-run --quiet
phase "cargo test: run"
mkdir -p target
set +e
# --no-fail-fast: every test binary runs, so one failure does not hide
# the others (nor shrink the count below).
cargo test --workspace --no-fail-fast 2>&1 | tee target/test.log
status=${PIPESTATUS[0]}
set -e
phase "Python package (wheel in a fresh venv, pytest)"
set +e
bash scripts/python-test.sh --profile dev 2>&1 | tee target/test-python.log
[[ ${PIPESTATUS[0]} -eq 0 ]] || status=1
set -e
phase "cluster (single-node Slurm on loopback)"
set +e
bash scripts/test-cluster.sh 2>&1 | tee target/test-cluster.log
[[ ${PIPESTATUS[0]} -eq 0 ]] || status=1
set -e
phase "the library without its optional features; every library crate packages alone"
# Last: the library alone resolves its dependencies' features apart from
# the workspace and compiles them again in check mode, which nothing above
# needs. `cargo check` under the exported wrapper is what `cargo clippy`
# runs.
set +e
cargo check -p eyereplay --no-default-features --quiet || status=1
for manifest in crates/*/Cargo.toml; do
  crate="$(basename "$(dirname "$manifest")")"
  [[ "$crate" == eyereplay-cli || "$crate" == eyereplay-py ]] && continue
  cargo package --list --allow-dirty -p "$crate" > /dev/null || { echo "test: $crate does not package alone" >&2; status=1; }
done
set -e
phase "done"
# One closing line over both runners.
passed=$(grep -oE 'test result: [a-zA-Z]+\. [0-9]+ passed' target/test.log | awk '{s+=$4} END {print s+0}')
failed=$(grep -oE 'test result: [a-zA-Z]+\. [0-9]+ passed; [0-9]+ failed' target/test.log | awk '{s+=$6} END {print s+0}')
read -r cp cf < <(grep -oE '^[0-9]+ passed, [0-9]+ failed' target/test-cluster.log | tail -1 | awk '{print $1, $3}') || true
passed=$((passed + ${cp:-0}))
failed=$((failed + ${cf:-0}))
# pytest's summary line: "N passed[, M failed][, ...] in S s"; the wheel-alone
# check after it counts as one test.
summary=$(grep -E '^(=+ )?[0-9]+ (passed|failed|error)' target/test-python.log | tail -1) || true
pp=$(grep -oE '[0-9]+ passed' <<< "$summary" | awk '{print $1}') || true
pf=$(grep -oE '[0-9]+ (failed|error)' <<< "$summary" | awk '{s+=$1} END {print s+0}') || true
if grep -q "the wheel alone: ok" target/test-python.log; then pp=$(( ${pp:-0} + 1 )); else pf=$(( ${pf:-0} + 1 )); fi
passed=$((passed + ${pp:-0}))
failed=$((failed + ${pf:-0}))
echo "${passed} passed, ${failed} failed"
exit "$status"
