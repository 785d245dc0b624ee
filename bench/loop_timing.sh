#!/usr/bin/env bash
# Loop timing of coopdynd in place, next to cyclictest and the warm kernel, in one script and one
# run: one Markdown table (bench/README.md, "Loop timing").
#
#   bench/loop_timing.sh [SECONDS=20] [BUILD_DIR=build] [SCENE=config/scenes/two_puma_load.yaml]
#   NETNS=NAME bench/loop_timing.sh ...   # run the udpm parts inside `ip netns exec NAME` (a private
#                                         # namespace with lo up and a multicast route on it)
#   ROWS=arrival bench/loop_timing.sh ... # only the event-driven rows, next to cyclictest and the
#                                         # fixed-rate estimate row
#   ROWS=receive bench/loop_timing.sh ... # the receive process against the loop reading the socket
#                                         # itself (realtime.receive_in_loop), sleeping and busy polling
#                                         # with a polling client, alternated for ROUNDS rounds (default
#                                         # 3), next to cyclictest FIFO
#   ROWS=inplace bench/loop_timing.sh ... # the default config (commands at 100 Hz and at 1 kHz) against
#                                         # the same with realtime.sched_fifo: false, in place (simulate) and on arrival
#                                         # (estimate; also with receive_priority 70 and with
#                                         # receive_in_loop), alternated for ROUNDS rounds (default 3),
#                                         # next to cyclictest SCHED_OTHER and SCHED_FIFO 80
#   ROWS=loaded bench/loop_timing.sh ...  # a loaded soak: the default config with commands at 1 kHz while
#                                         # two `yes > /dev/null` load the machine (each bounded by
#                                         # SECONDS), against the same idle, alternated for ROUNDS rounds
#                                         # (default 3); the outputs the publisher thread dropped in the
#                                         # ticks column (BASELINE=DIR: also that build's, loaded)
#   BASELINE=DIR bench/loop_timing.sh ... # also the event-driven rows of another build's coopdynd
#                                         # (DIR/bin/coopdynd: before and after a change, in one run)
#
# Rows (each SECONDS long, at 1 kHz, over udpm on loopback, ttl=0):
#   daemon rows: coopdynd on a private URL (event-driven rows: heartbeats at 10 Hz, so that their
#     lateness and compute are the states') while `coopdyn send --measure-latency` publishes at
#     100 Hz (torque commands in simulate mode, the states of a short `coopdyn sim` in estimate
#     mode; "commands at 1 kHz": every tick a new command, as a controller sends) and times each one
#     from its publish to the first output carrying its seq. The
#     daemon's summary gives wake-up lateness (wake-up minus the deadline; in the event-driven
#     row, wake-up minus the state's receipt in the receive process) and compute (wake-up to the
#     end of the tick: handoff, dynamics, wrenches, encoding, and the hand-off of the bytes to the
#     publisher thread; lcm_publish itself on arrival and in the "the loop publishing" row,
#     realtime.publisher_thread: false) over every tick.
#   cyclictest rows: cyclictest -t 1 -i 1000 with the same policy (it holds /dev/cpu_dma_latency
#     at 0 itself), percentiles from its histogram.
#   warm: build/bin/loop_bench's ServiceLoop::tick() of the same scene (BM_TickPaced, back to back,
#     warm caches, null bus, p50): the in-place compute p50 is given as a multiple of it.
#   where the time goes: the same tick p50 / p99 slept to 1 ms deadlines (cold caches), then also
#     publishing over udpm on loopback with no subscriber and with one (loop_bench BM_TickPaced).
#   LCM round trip alone: build/bin/lcm_pingpong, two processes that only talk LCM (100 Hz,
#     messages of output_t's size both ways): the transport's and the client library's share.
# Daemon variants: "default config" = none of the options below set (realtime.sched_fifo auto: SCHED_FIFO
#   80 as root); "SCHED_OTHER" = realtime.sched_fifo false; "the loop publishing" = realtime.publisher_thread false (the loop calls
#   lcm_publish itself, as on arrival); "rt" = SCHED_FIFO 80 + mlockall (needs root; refusals are logged); "+ tricks" =
#   rt + /dev/cpu_dma_latency held at 0 + the loop pinned to CPU 1 with the receive thread and
#   process on the others + inputs on their own port (lcm_url_in: the receive process never sees
#   the daemon's own outputs); "+ spin 50" = that + realtime.spin_us 50; "+ busy poll" = that +
#   realtime.busy_poll (event-driven only: the loop polls for states, a whole CPU); "receive in loop" =
#   realtime.receive_in_loop (event-driven only: the loop reads the input socket itself, no receive
#   process; sleeping in ppoll on it, or polling it with busy poll); "polling client"
#   = `coopdyn send --busy-poll` (its read-back thread polls LCM without sleeping, as a real-time
#   controller polls each cycle), next to the LCM round trip alone with both ends polling
#   (lcm_pingpong --busy-poll).
set -euo pipefail
cd "$(dirname "$0")/.."
DUR=${1:-20}
BUILD=$(cd "${2:-build}" && pwd)
SCENE=${3:-config/scenes/two_puma_load.yaml}
NS=()
[ -n "${NETNS:-}" ] && NS=(ip netns exec "$NETNS")
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
PORT=$((20000 + $$ % 20000))
URL="udpm://239.255.76.67:$PORT?ttl=0"
URL_IN="udpm://239.255.76.67:$((PORT + 1))?ttl=0"

CYCLICTEST=1  # its rows are the bare kernel's wake-up next to the daemon's; without it they are skipped, said so
command -v cyclictest >/dev/null || { CYCLICTEST=0; echo "cyclictest missing: its rows are skipped (Debian: apt-get install rt-tests)" >&2; }
for b in coopdynd coopdyn loop_bench lcm_pingpong; do
  [ -x "$BUILD/bin/$b" ] || { echo "build first: cmake --build ${2:-build} -j2 --target coopdynd coopdyn loop_bench lcm_pingpong (missing bin/$b)" >&2; exit 1; }
done
if ! "${NS[@]}" ip route show 224.0.0.0/4 2>/dev/null | grep -q .; then
  echo "no multicast route: 'ip route add 224.0.0.0/4 dev lo' as root, or NETNS=a namespace that has one" >&2; exit 1
fi

echo "== machine: $(nproc) CPUs, $(uname -r), $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //')"
echo "== load before: $(cut -d' ' -f1-3 /proc/loadavg)"
"$BUILD/bin/coopdyn" sim --scene "$SCENE" --duration 2 --dt 0.001 --out "$TMP/states.csv" 2>/dev/null
joint=$("$BUILD/bin/coopdyn" eval --scene "$SCENE" | python3 -c 'import json,sys; print(json.load(sys.stdin)["coordinates"]["v"][-1])')

# daemon ROW_NAME MODE EXTRA_YAML [trigger [BUILD_DIR of coopdynd [flags of coopdyn send [send rate, Hz]]]]
daemon() {
  local name=$1 mode=$2 extra=$3 trigger=${4:-tick} url_in=$URL bin=${5:-$BUILD}/bin send_flags=${6:-} rate=${7:-100}
  {
    # on arrival the rate is only the heartbeat's without a fresh state: at 10 Hz the few heartbeats
    # (before the first state, after the last) leave the lateness and compute columns to the states
    if [ "$trigger" = arrival ]; then echo "rate_hz: 10"; else echo "rate_hz: 1000"; fi
    echo "mode: $mode"
    [ "$mode" = estimate ] && echo "trigger: $trigger"
    printf '%b\n' "$extra"
  } > "$TMP/cfg.yaml"
  grep -q "lcm_url_in" "$TMP/cfg.yaml" && url_in=$URL_IN
  "${NS[@]}" "$bin/coopdynd" --scene "$SCENE" --config "$TMP/cfg.yaml" --lcm-url "$URL" --duration "$DUR" \
    > "$TMP/d.out" 2> "$TMP/d.err" &
  local pid=$!
  sleep 1
  if [ "$mode" = simulate ]; then
    "${NS[@]}" "$BUILD/bin/coopdyn" send --scene "$SCENE" --lcm-url "$url_in" --output-url "$URL" --rate "$rate" \
      --duration "$((DUR - 3))" --torque "$joint:constant:0.1" --measure-latency $send_flags > "$TMP/s.out" 2>&1 || true
  else
    "${NS[@]}" "$BUILD/bin/coopdyn" send --scene "$SCENE" --lcm-url "$url_in" --output-url "$URL" --rate "$rate" \
      --duration "$((DUR - 3))" --states "$TMP/states.csv" --measure-latency $send_flags > "$TMP/s.out" 2>&1 || true
  fi
  wait $pid
  grep -E "refused|not held" "$TMP/d.err" | sed 's/^/   /' >&2 || true
  python3 - "$name" "$TMP/d.out" "$TMP/s.out" "$TMP/d.err" >> "$TMP/rows" <<'PY'
import re, sys
name, d, s = sys.argv[1], open(sys.argv[2]).read(), open(sys.argv[3]).read()
dropped = re.search(r"publisher thread: (\d+) message\(s\) dropped", open(sys.argv[4]).read())
m = re.search(r"after (\d+) ticks.*?overruns (\d+).*lateness us p50 ([\d.]+) p99 ([\d.]+) p99.9 ([\d.]+) max ([\d.]+); "
              r"compute us p50 ([\d.]+) p99 ([\d.]+) p99.9 ([\d.]+) max ([\d.]+)", d)
l = re.search(r"over (\d+) commands: min ([\d.]+) us, p50 ([\d.]+) us, p99 ([\d.]+) us", s)
if not m:
    print(f"{name}|daemon summary missing|" + d.strip().replace("|", "/")[:200]); sys.exit()
t, ov, lp50, lp99, lp999, lmax, cp50, cp99, cp999, cmax = m.groups()
lat = f"{l.group(2)}|{l.group(3)}|{l.group(4)}|{l.group(1)}" if l else "|||0"
drops = f" ({dropped.group(1)} outputs dropped)" if dropped else ""
print(f"{name}|{lp50}|{lp99}|{lp999}|{lmax}|{cp50}|{cp99}|{cp999}|{t}/{ov}{drops}|{lat}")
PY
}

# cyclictest ROW_NAME [policy args]
cyclic() {
  local name=$1; shift
  if [ "$CYCLICTEST" = 0 ]; then echo "$name|skipped: cyclictest missing (rt-tests)" >> "$TMP/rows"; return; fi
  cyclictest -q -t 1 -i 1000 -D "${DUR}s" -h 20000 --histfile="$TMP/ct.hist" "$@" > "$TMP/ct.out" 2>&1 || true
  python3 - "$name" "$TMP/ct.hist" >> "$TMP/rows" <<'PY'
import sys
counts, over, mx = [], 0, float("nan")
for line in open(sys.argv[2]):
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
    return ">20000"  # beyond the histogram (20 ms)
print(f"{sys.argv[1]}|{pct(.5)}|{pct(.99)}|{pct(.999)}|{mx}|||||||||")
PY
}

RT="realtime: {sched_fifo: true, priority: 80, mlockall: true"
TRICKS="$RT, cpu: 1, cpu_dma_latency_zero: true}\nlcm_url_in: \"$URL_IN\""
: > "$TMP/rows"
with() { printf '%s' "$TRICKS" | sed "s/cpu_dma_latency_zero: true}/cpu_dma_latency_zero: true, $1}/"; }
# receive: A/B rounds, each row right after the other, so that a load that changes over the run
# reaches both
receive_rounds() {
  cyclic "cyclictest, SCHED_FIFO 80 -m" -p 80 -m
  for r in $(seq "${ROUNDS:-3}"); do
    daemon "coopdynd estimate on arrival, rt + tricks (round $r)" estimate "$TRICKS" arrival
    daemon "coopdynd estimate on arrival, rt + tricks, receive in loop (round $r)" estimate \
      "$(with "receive_in_loop: true")" arrival
    daemon "coopdynd estimate on arrival, rt + tricks + busy poll, polling client (round $r)" estimate \
      "$(with "busy_poll: true")" arrival "$BUILD" --busy-poll
    daemon "coopdynd estimate on arrival, rt + tricks + busy poll, receive in loop, polling client (round $r)" estimate \
      "$(with "busy_poll: true, receive_in_loop: true")" arrival "$BUILD" --busy-poll
  done
}
# inplace: the default config (realtime.sched_fifo auto: SCHED_FIFO 80 as root; cpu_dma_latency_zero)
# against the same with sched_fifo: false, in place and on arrival, A/B rounds as above
inplace_rounds() {
  cyclic "cyclictest, SCHED_OTHER"
  cyclic "cyclictest, SCHED_FIFO 80 -m" -p 80 -m
  for r in $(seq "${ROUNDS:-3}"); do
    daemon "coopdynd simulate, default config (round $r)" simulate ""
    daemon "coopdynd simulate, default config, commands at 1 kHz (round $r)" simulate "" tick "$BUILD" "" 1000
    daemon "coopdynd simulate, sched_fifo: false (round $r)" simulate "realtime: {sched_fifo: false}"
    daemon "coopdynd estimate on arrival, default config (round $r)" estimate "" arrival
    daemon "coopdynd estimate on arrival, receive_priority: 70 (round $r)" estimate "realtime: {receive_priority: 70}" arrival
    daemon "coopdynd estimate on arrival, receive in loop (round $r)" estimate "realtime: {receive_in_loop: true}" arrival
    daemon "coopdynd estimate on arrival, sched_fifo: false (round $r)" estimate "realtime: {sched_fifo: false}" arrival
  done
}
# loaded: two CPU hogs at SCHED_OTHER (each ended by timeout after SECONDS + 2 s), the daemon's row
# under them, then the same row idle
loaded_rounds() {
  for r in $(seq "${ROUNDS:-3}"); do
    timeout "$((DUR + 2))" yes > /dev/null & timeout "$((DUR + 2))" yes > /dev/null &
    daemon "coopdynd simulate, default config, commands at 1 kHz, 2 x yes (round $r)" simulate "" tick "$BUILD" "" 1000
    wait || true
    if [ -n "${BASELINE:-}" ]; then
      timeout "$((DUR + 2))" yes > /dev/null & timeout "$((DUR + 2))" yes > /dev/null &
      daemon "coopdynd simulate, default config, commands at 1 kHz, 2 x yes, BASELINE build (round $r)" simulate "" \
        tick "$(cd "$BASELINE" && pwd)" "" 1000
      wait || true
    fi
    daemon "coopdynd simulate, default config, commands at 1 kHz, idle (round $r)" simulate "" tick "$BUILD" "" 1000
  done
}
if [ "${ROWS:-all}" = receive ]; then
  receive_rounds
elif [ "${ROWS:-all}" = loaded ]; then
  loaded_rounds
elif [ "${ROWS:-all}" = inplace ]; then
  inplace_rounds
else
  if [ "${ROWS:-all}" != arrival ]; then
    daemon "coopdynd simulate, default config" simulate ""
    # as a controller sends: a new command every tick (1 kHz), from another process
    daemon "coopdynd simulate, default config, commands at 1 kHz" simulate "" tick "$BUILD" "" 1000
    daemon "coopdynd simulate, SCHED_OTHER" simulate "realtime: {sched_fifo: false}"
    # the same with the loop publishing each output itself (lcm_publish inside its compute window)
    daemon "coopdynd simulate, SCHED_OTHER, the loop publishing" simulate "realtime: {sched_fifo: false, publisher_thread: false}"
  fi
  cyclic "cyclictest, SCHED_OTHER"
  [ "${ROWS:-all}" != arrival ] && daemon "coopdynd simulate, rt" simulate "$RT}"
  cyclic "cyclictest, SCHED_FIFO 80 -m" -p 80 -m
  if [ "${ROWS:-all}" != arrival ]; then
    daemon "coopdynd simulate, rt + tricks" simulate "$TRICKS"
    daemon "coopdynd simulate, rt + tricks + spin 50" simulate "$(with "spin_us: 50")"
  fi
  daemon "coopdynd estimate at the tick, rt + tricks" estimate "$TRICKS" tick
  [ -n "${BASELINE:-}" ] && daemon "coopdynd estimate on arrival, rt + tricks, BASELINE build" estimate "$TRICKS" arrival \
    "$(cd "$BASELINE" && pwd)"
  daemon "coopdynd estimate on arrival, rt + tricks" estimate "$TRICKS" arrival
  daemon "coopdynd estimate on arrival, rt + tricks + busy poll" estimate "$(with "busy_poll: true")" arrival
  [ -n "${BASELINE:-}" ] && daemon "coopdynd estimate on arrival, rt + tricks + busy poll, polling client, BASELINE build" \
    estimate "$(with "busy_poll: true")" arrival "$(cd "$BASELINE" && pwd)" --busy-poll
  daemon "coopdynd estimate on arrival, rt + tricks + busy poll, polling client" estimate "$(with "busy_poll: true")" arrival \
    "$BUILD" --busy-poll
  # the loop reading the input socket itself (realtime.receive_in_loop: no receive process), sleeping and polling
  daemon "coopdynd estimate on arrival, rt + tricks, receive in loop" estimate "$(with "receive_in_loop: true")" arrival
  daemon "coopdynd estimate on arrival, rt + tricks + busy poll, receive in loop" estimate \
    "$(with "busy_poll: true, receive_in_loop: true")" arrival
  daemon "coopdynd estimate on arrival, rt + tricks + busy poll, receive in loop, polling client" estimate \
    "$(with "busy_poll: true, receive_in_loop: true")" arrival "$BUILD" --busy-poll
fi

LOOP_BENCH_SCENE=$(realpath "$SCENE") "${NS[@]}" taskset -c 1 "$BUILD/bin/loop_bench" --benchmark_filter='BM_TickPaced' \
  --benchmark_format=csv 2>/dev/null > "$TMP/warm.csv" || true
# the transport alone: two processes that only talk LCM, messages of output_t's size (lcm_pingpong.cc)
BYTES=$(python3 - "$TMP/warm.csv" <<'PY' 2>/dev/null || echo 4096
import csv, sys
head = None
for r in csv.reader(open(sys.argv[1])):
    if r and r[0] == "name": head = r
    elif head and r and r[0].startswith("BM_TickPaced/1/0/0") and "bytes/tick" in head and r[head.index("bytes/tick")]:
        print(round(float(r[head.index("bytes/tick")]))); sys.exit()
print(4096)
PY
)
# pingpong ROW_SUFFIX [--busy-poll]: both ends sleeping, or both polling
pingpong() {
  "${NS[@]}" "$BUILD/bin/lcm_pingpong" echo "$URL" "$DUR" ${2:-} & local echo_pid=$!
  sleep 0.5
  "${NS[@]}" "$BUILD/bin/lcm_pingpong" ping "$URL" "$BYTES" "$((100 * (DUR - 3)))" ${2:-} > "$TMP/pp.out" 2>&1 || true
  wait $echo_pid || true
  python3 - "$TMP/pp.out" "$1" >> "$TMP/rows" <<'PY'
import re, sys
m = re.search(r"over (\d+) of \d+ messages of (\d+) bytes: min ([\d.]+) us, p50 ([\d.]+) us, p99 ([\d.]+) us", open(sys.argv[1]).read())
if m: print(f"LCM round trip alone (lcm_pingpong), {m.group(2)} bytes each way{sys.argv[2]}|||||||||{m.group(3)}|{m.group(4)}|{m.group(5)}|{m.group(1)}")
PY
}
pingpong ""
pingpong ", both ends polling" --busy-poll
echo "== load after: $(cut -d' ' -f1-3 /proc/loadavg)"
python3 - "$TMP/rows" "$TMP/warm.csv" "$(basename "$SCENE" .yaml)" <<'PY'
import csv, sys
# BM_TickPaced/MODE/PACED/BUS: p50 and p99 per (mode, paced, bus)
paced, size = {}, {}
head = None
for r in csv.reader(open(sys.argv[2])):
    if r and r[0] == "name": head = r
    if head and r and r[0].startswith("BM_TickPaced/"):
        m, p, b = (int(x) for x in r[0].split("/")[1:4])
        mode = "estimate" if m else "simulate"
        get = lambda c: float(r[head.index(c)]) if c in head and r[head.index(c)] else None
        paced[(mode, p, b)] = (get("p50_us"), get("p99_us"))
        if (p, b) == (0, 0) and get("bytes/tick"): size[mode] = get("bytes/tick")
warm = {mode: paced[(mode, 0, 0)][0] for mode in ("simulate", "estimate") if (mode, 0, 0) in paced}
print(f"| 1 kHz, {sys.argv[3]} | lateness p50 | p99 | p99.9 | max | compute p50 | p99 | p99.9 | compute p50 / warm tick "
      "| ticks / overruns | latency min | p50 | p99 | messages |")
print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
for line in open(sys.argv[1]):
    f = line.rstrip("\n").split("|")
    f += [""] * (13 - len(f))
    name = f[0]
    ratio = ""
    if f[5] and name.startswith("coopdynd"):
        w = warm.get("simulate" if "simulate" in name else "estimate")
        if w: ratio = f"{float(f[5]) / w:.2f}x"
    us = lambda x: f"{x} µs" if x not in ("", "nan") and not x.startswith("skipped") else x
    print(f"| {name} | {us(f[1])} | {us(f[2])} | {us(f[3])} | {us(f[4])} | {us(f[5])} | {us(f[6])} | {us(f[7])} | {ratio} "
          f"| {f[8]} | {us(f[9])} | {us(f[10])} | {us(f[11])} | {f[12]} |")
print()
print("warm ServiceLoop::tick() p50 (loop_bench BM_TickPaced, back to back, null bus, taskset -c 1): " +
      ", ".join(f"{k} {v:.2f} µs" for k, v in sorted(warm.items())) +
      "; output_t " + ", ".join(f"{k} {v:.0f} bytes" for k, v in sorted(size.items())) + ".")
print()
print("Where the time goes: the same tick() outside the daemon (loop_bench BM_TickPaced, 3000 ticks each, "
      "taskset -c 1), p50 / p99:")
print()
print("| tick() | back to back, null bus | slept to 1 ms deadlines, null bus | slept, udpm, no subscriber | slept, udpm + a subscriber |")
print("|---|---|---|---|---|")
cell = lambda t: f"{t[0]:.1f} / {t[1]:.1f} µs" if t and t[0] is not None else "n/a"
for mode in ("simulate", "estimate"):
    print(f"| {mode} | " + " | ".join(cell(paced.get((mode, p, b))) for p, b in ((0, 0), (1, 0), (1, 2), (1, 1))) + " |")
PY
