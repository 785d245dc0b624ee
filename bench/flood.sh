#!/usr/bin/env bash
# bench/flood.sh [BUILD_DIR=build] [RUNS=3]: the command path under a flood of junk datagrams
# (tests/daemon/flood_daemon_test.cc: 300 valid commands, each after 20 junk datagrams, random or carrying
# the command fingerprint), run RUNS times; prints each run's [flood] line: junk rate, valid commands
# applied and lost (the test asserts only that every loss is counted), and the daemon's tick rate
# during the flood. Needs a multicast route (ip route add 224.0.0.0/4 dev lo).
set -euo pipefail
build=${1:-build}
runs=${2:-3}
bin="$build/bin/coopdynd_tests"
[ -x "$bin" ] || bin=$(find "$build" -name coopdynd_tests -type f -perm -u+x | head -1)
[ -x "$bin" ] || { echo "flood.sh: coopdynd_tests not found under $build (build it first)" >&2; exit 1; }
for r in $(seq 1 "$runs"); do
  "$bin" --gtest_filter='DaemonFlood.ValidCommandLossCounted' | grep -E '^\[flood\]|FAILED' | sed "s/^/run $r: /"
done
