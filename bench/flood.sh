#!/usr/bin/env bash
# bench/flood.sh [BUILD_DIR=build] [RUNS=3]: the command path under a flood of junk datagrams
# (tests/daemon/flood_daemon_test.cc: 300 valid commands at 100 Hz, each after 20 junk datagrams
# published by one thread as fast as it goes): random junk, junk that carries the command fingerprint,
# then with authentication on junk of four kinds in turn (garbage after the fingerprint, unsigned,
# forged MAC, a replayed valid command) against signed commands. RUNS times; prints each run's [flood]
# lines: junk rate, valid commands applied and lost (without authentication the test asserts only that
# every loss is counted; with it, that at least 99 % are applied where the receive path ran at
# SCHED_FIFO throughout), where the junk went, and the
# daemon's tick rate during the flood, and whether the receive process and thread got SCHED_FIFO
# (realtime.receive_priority 70; as root; with sched_fifo true in the authenticated flood, auto in
# the others) and were stepped down. COOPDYN_FLOOD_REALTIME='{...}' sets the daemon's realtime mapping instead (e.g.
# '{receive_priority: 70}': sched_fifo auto, whose guard steps a busy receive path down). Needs a multicast route (ip route add
# 224.0.0.0/4 dev lo).
set -euo pipefail
build=${1:-build}
runs=${2:-3}
bin="$build/bin/coopdynd_tests"
[ -x "$bin" ] || bin=$(find "$build" -name coopdynd_tests -type f -perm -u+x | head -1)
[ -x "$bin" ] || { echo "flood.sh: coopdynd_tests not found under $build (build it first)" >&2; exit 1; }
echo "load: $(uptime)"
for r in $(seq 1 "$runs"); do
  "$bin" --gtest_filter='DaemonFlood.ValidCommandLossCounted:DaemonFlood.WithAuthentication*' |
    grep -E '^\[flood\]|FAILED|Failure' | sed "s/^/run $r: /"
done
