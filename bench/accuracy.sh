#!/usr/bin/env bash
# Error against run time, regenerated with one command:
#
#   bench/accuracy.sh [BUILD_DIR] [SCENE...]
#
# Builds accuracy_sweep in BUILD_DIR (default: build) if needed, runs the sweep and writes
# bench/results/accuracy_<scene>.csv, docs/accuracy_<scene>.png, bench/results/accuracy_summary.csv
# and the generated table at the end of bench/README.md. With SCENE names only those scenes are run
# and re-plotted (the summary and the table are rebuilt from every scene's CSV, so the others' parts
# are unchanged, and the "Last regenerated" line of the whole run stays); the log of a whole run is
# bench/results/accuracy_log.txt, of a partial one BUILD_DIR/accuracy_log_partial.txt.
# If BUILD_DIR had the benchmarks off, they are turned on for the sweep and off again afterwards.
# Single-threaded; the whole run's wall time is the "Last regenerated" line of bench/README.md.
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
  trap 'cmake "$build" -DCOOPDYN_BUILD_BENCH=OFF >/dev/null' EXIT  # as it was
fi
cmake --build "$build" --target accuracy_sweep -j2

mkdir -p "$root/bench/results" "$root/docs"
machine="$(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//')"
if [ $# -eq 0 ]; then
  "$build/bin/accuracy_sweep" "$root/bench/results" | tee "$root/bench/results/accuracy_log.txt"
  /usr/bin/python3 "$root/bench/plot_accuracy.py" "$root" --seconds $(( $(date +%s) - start )) --machine "$machine"
else
  "$build/bin/accuracy_sweep" "$root/bench/results" "$@" | tee "$build/accuracy_log_partial.txt"
  /usr/bin/python3 "$root/bench/plot_accuracy.py" "$root" --scenes "$@"
fi
