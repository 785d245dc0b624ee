#!/usr/bin/env bash
# How long `coopdyn log` takes a person: a daemon log converted and plotted, and a simulator's CSV
# plotted. Nothing is asserted here: the tests check what is drawn (tests/clients/cli/log_plot_test.py).
#
#   bench/log_plot.sh [SECONDS=10] [BUILD_DIR=build] [PORT=7793]
#
# Records SECONDS of coopdynd on two_puma_load at 1 kHz with lcm-logger on a private loopback port
# (udpm://239.255.76.67:PORT?ttl=0), then times, wall and CPU (user + sys, the children's too):
# `coopdyn log --no-plot` (the conversion alone), `coopdyn log` (conversion and plots), and
# `coopdyn sim` of 2 s at 1 ms followed by `coopdyn log --in sim.csv` (the plots alone). Prints the
# log's size and one line per step.
set -euo pipefail
cd "$(dirname "$0")/.."
SECONDS_RUN=${1:-10}
BUILD=$(cd "${2:-build}" && pwd)
PORT=${3:-7793}
URL="udpm://239.255.76.67:$PORT?ttl=0"
SCENE=config/scenes/two_puma_load.yaml
for b in coopdyn coopdynd; do
  [ -x "$BUILD/bin/$b" ] || { echo "build first: cmake --build $BUILD --target coopdyn coopdynd" >&2; exit 1; }
done
command -v lcm-logger > /dev/null || { echo "lcm-logger missing (Debian: apt-get install liblcm-bin)" >&2; exit 1; }
tmp=$(mktemp -d)
logger=
cleanup() { [ -n "$logger" ] && kill "$logger" 2> /dev/null; rm -rf "$tmp"; }
trap cleanup EXIT
lcm-logger --lcm-url="$URL" -f "$tmp/run.lcmlog" > "$tmp/logger.out" 2>&1 &
logger=$!
sleep 1
"$BUILD/bin/coopdynd" --scene "$SCENE" --duration "$SECONDS_RUN" --lcm-url "$URL" > "$tmp/daemon.out" 2>&1
sleep 0.5
kill -INT "$logger"
wait "$logger" || true
logger=
echo "log: $SECONDS_RUN s of $SCENE at 1 kHz, $(stat -c %s "$tmp/run.lcmlog") bytes; load average $(cut -d' ' -f1-3 /proc/loadavg)"
TIMEFORMAT='%R s wall, %U s user + %S s sys'
step() {  # what, command...
  local what=$1
  shift
  local t
  t=$( { time "$@" > /dev/null 2> "$tmp/err" ; } 2>&1 ) || { cat "$tmp/err" >&2; exit 1; }
  echo "$what: $t"
}
step "coopdyn log --no-plot (conversion)" "$BUILD/bin/coopdyn" log --in "$tmp/run.lcmlog" --out "$tmp/a" --no-plot
step "coopdyn log (conversion and plots)" "$BUILD/bin/coopdyn" log --in "$tmp/run.lcmlog" --out "$tmp/b"
ls "$tmp/b"/*.png > /dev/null
"$BUILD/bin/coopdyn" sim --scene "$SCENE" --duration 2 --dt 0.001 --torque arm1.q1:pulse:1.0:0.5:1.0 \
  --out "$tmp/sim.csv" 2> /dev/null
step "coopdyn log --in sim.csv (2 s at 1 ms: plots)" "$BUILD/bin/coopdyn" log --in "$tmp/sim.csv" --out "$tmp/c"
echo "load average after: $(cut -d' ' -f1-3 /proc/loadavg)"
