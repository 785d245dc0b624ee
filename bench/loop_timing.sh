#!/usr/bin/env bash
# Loop timing of coopdynd, measured in place, next to cyclictest on the same machine.
#
#   bench/loop_timing.sh [SECONDS=60] [BUILD_DIR=build] [SCENE=config/scenes/two_puma_load.yaml]
#   RT=1 bench/loop_timing.sh ...   # both with SCHED_FIFO 80 (+ mlockall for the daemon); needs root
#
# 1. coopdynd at 1 kHz for SECONDS on a private udpm URL (ttl=0), while `coopdyn send` publishes a
#    torque command at 100 Hz and measures the end-to-end latency (command publish -> first output
#    whose input_seq is that command, received back by the sender). The daemon's summary line gives
#    wake-up lateness and compute-time percentiles over every tick of the run.
# 2. cyclictest (rt-tests) for SECONDS at the same 1000 us interval, one thread, the same policy;
#    its histogram gives the same percentiles of wake-up latency.
set -euo pipefail
cd "$(dirname "$0")/.."
DUR=${1:-60}
BUILD=${2:-build}
SCENE=${3:-config/scenes/two_puma_load.yaml}
RT=${RT:-0}
URL="udpm://239.255.76.67:$((20000 + $$ % 20000))?ttl=0"
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT

command -v cyclictest >/dev/null || { echo "cyclictest missing: apt-get install rt-tests" >&2; exit 1; }
[ -x "$BUILD/bin/coopdynd" ] || { echo "build first: cmake --build $BUILD" >&2; exit 1; }
if ! ip route show 224.0.0.0/4 2>/dev/null | grep -q .; then
  echo "no multicast route: run 'ip route add 224.0.0.0/4 dev lo' as root" >&2; exit 1
fi

{
  echo "rate_hz: 1000"
  echo "stats_period_s: 1.0"
  if [ "$RT" = 1 ]; then echo "realtime: {sched_fifo: true, priority: 80, mlockall: true}"; fi
} > "$TMP/cfg.yaml"
CT_POLICY=(); [ "$RT" = 1 ] && CT_POLICY=(-p 80 -m)

echo "== machine: $(nproc) CPUs, $(uname -r), $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //')"
echo "== load before: $(cut -d' ' -f1-3 /proc/loadavg)"
echo "== coopdynd ${DUR} s at 1 kHz, scene $SCENE, RT=$RT"
"$BUILD/bin/coopdynd" --scene "$SCENE" --config "$TMP/cfg.yaml" --lcm-url "$URL" --duration "$DUR" \
  > "$TMP/daemon.out" 2> "$TMP/daemon.err" &
DPID=$!
sleep 1
joint=$("$BUILD/bin/coopdyn" eval --scene "$SCENE" | python3 -c 'import json,sys; print(json.load(sys.stdin)["coordinates"]["v"][-1])')
"$BUILD/bin/coopdyn" send --scene "$SCENE" --lcm-url "$URL" --rate 100 --duration "$((DUR - 3))" \
  --torque "$joint:constant:0.1" --measure-latency > "$TMP/send.out"
wait $DPID
grep -E "refused|SCHED_FIFO|mlockall|pinned" "$TMP/daemon.err" || true
cat "$TMP/daemon.out"
grep "latency" "$TMP/send.out"

echo "== cyclictest ${DUR} s, interval 1000 us, 1 thread ${CT_POLICY[*]:-(SCHED_OTHER)}"
cyclictest -q -t 1 -i 1000 -D "${DUR}s" -h 20000 --histfile="$TMP/ct.hist" "${CT_POLICY[@]}" > "$TMP/ct.out" 2>&1 || true
python3 - "$TMP/ct.hist" <<'PY'
import sys
counts = []
over = 0
for line in open(sys.argv[1]):
    if line.startswith("#"):
        if "Histogram Overflows" in line: over = int(line.split(":")[1].split()[0])
        if "Max Latencies" in line: mx = int(line.split(":")[1].split()[0])
        continue
    p = line.split()
    if len(p) >= 2: counts.append((int(p[0]), int(p[1])))
n = sum(c for _, c in counts) + over
def pct(q):
    r, s = q * (n - 1) + 1, 0
    for us, c in counts:
        s += c
        if s >= r: return us
    return float("nan")
print(f"cyclictest: {n} wake-ups: latency us p50 {pct(.5)} p99 {pct(.99)} p99.9 {pct(.999)} max {mx}")
PY
echo "== load after: $(cut -d' ' -f1-3 /proc/loadavg)"
