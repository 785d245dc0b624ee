#!/usr/bin/env bash
# tests/census.sh BUILD_DIR [RUNS=5] [LOADERS=2] [CTEST_ARGS...]: the flake census. Runs the whole
# suite of BUILD_DIR (ctest -j2, as the README's test command does) RUNS times in a row while LOADERS
# busy loops keep the CPUs loaded, and prints one line per run (passed/failed, failing tests, wall
# time) and a summary. Exits non-zero if any run failed. For the sanitizer build as .ci/run runs it:
# tests/census.sh build-asan 2 2 -LE install
set -uo pipefail
build=${1:?usage: tests/census.sh BUILD_DIR [RUNS=5] [LOADERS=2]}
runs=${2:-5}
loaders=${3:-2}
shift $(( $# < 3 ? $# : 3 ))
[ -f "$build/CTestTestfile.cmake" ] || { echo "census.sh: $build is not a configured build folder" >&2; exit 2; }
pids=()
stop_load() { for p in "${pids[@]}"; do kill "$p" 2>/dev/null; done; }
trap stop_load EXIT
for _ in $(seq 1 "$loaders"); do (while :; do :; done) & pids+=($!); done
passed=0
for r in $(seq 1 "$runs"); do
  t0=$(date +%s)
  log=$(mktemp)
  ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1} UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1} \
    ctest --test-dir "$build" --output-on-failure -j2 "$@" > "$log" 2>&1
  rc=$?
  t=$(( $(date +%s) - t0 ))
  summary=$(grep -E 'tests passed|tests failed' "$log" | tail -1)
  if [ $rc -eq 0 ]; then
    passed=$((passed + 1)); echo "run $r/$runs: passed in ${t} s ($summary)"
  else
    echo "run $r/$runs: FAILED in ${t} s ($summary)"
    sed -n '/The following tests FAILED/,$p' "$log"
    cp "$log" "$build/census_run_$r.log"; echo "  (full output: $build/census_run_$r.log)"
  fi
  rm -f "$log"
done
echo "census: $passed/$runs runs passed with $loaders busy loops on $(nproc) CPUs ($build)"
[ "$passed" -eq "$runs" ]
