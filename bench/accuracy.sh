#!/usr/bin/env bash
# Error against run time (issue 5), regenerated with one command:
#
#   bench/accuracy.sh [BUILD_DIR] [SCENE...]
#
# Builds accuracy_sweep in BUILD_DIR (default: build) if needed, runs the sweep (all six scenes, or
# the ones named), writes bench/results/accuracy_<scene>.csv, bench/results/accuracy_summary.csv,
# docs/accuracy_<scene>.png and the generated table at the end of bench/README.md.
# Single-threaded; about 4 minutes on the project's 2-core VM (see bench/README.md).
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${1:-build}"
shift || true
case "$build" in /*) ;; *) build="$root/$build" ;; esac

start=$(date +%s)
if [ ! -f "$build/CMakeCache.txt" ]; then
  cmake -S "$root" -B "$build" -DCOOPDYN_BUILD_BENCH=ON >/dev/null
elif ! grep -q '^COOPDYN_BUILD_BENCH:BOOL=ON' "$build/CMakeCache.txt"; then
  cmake "$build" -DCOOPDYN_BUILD_BENCH=ON >/dev/null
fi
cmake --build "$build" --target accuracy_sweep -j2

mkdir -p "$root/bench/results" "$root/docs"
"$build/bin/accuracy_sweep" "$root/bench/results" "$@" | tee "$root/bench/results/accuracy_log.txt"

machine="$(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//')"
/usr/bin/python3 "$root/bench/plot_accuracy.py" "$root" --seconds $(( $(date +%s) - start )) --machine "$machine"
