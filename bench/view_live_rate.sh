#!/usr/bin/env bash
# Does a WebSocket client of `coopdyn view --live` that never reads slow coopdynd down? (The test
# ViewLive.ClientThatNeverReadsIsDroppedFrom asserts what the viewer does with such a client; the
# rate is measured here, not asserted.)
#
#   bench/view_live_rate.sh [SECONDS=10] [BUILD_DIR=build] [RATE_HZ=1000]
#
# Three runs of SECONDS each: coopdynd on two_puma_load at RATE_HZ over udpm on loopback (ttl=0),
# `coopdyn view --live --rate 1000` subscribed to it, and no WebSocket client / one client that
# reads everything / one that connects and never reads (4 KiB receive buffer). Per run: the
# daemon's ticks per second, overruns and lateness p50/p99 from its summary line, and the viewer's
# /stats at the end (frames framed, sent, dropped).
set -euo pipefail
cd "$(dirname "$0")/.."
DUR=${1:-10}
BUILD=$(cd "${2:-build}" && pwd)
RATE=${3:-1000}
SCENE=config/scenes/two_puma_load.yaml
TMP=$(mktemp -d)
PIDS=()
trap 'for p in "${PIDS[@]}"; do kill "$p" 2>/dev/null || true; done; rm -rf "$TMP"' EXIT
URL="udpm://239.255.76.67:$((20000 + $$ % 20000))?ttl=0"
for b in coopdynd coopdyn; do
  [ -x "$BUILD/bin/$b" ] || { echo "build first: cmake --build $BUILD (missing bin/$b)" >&2; exit 1; }
done
ip route show 224.0.0.0/4 2>/dev/null | grep -q . ||
  { echo "no multicast route: 'ip route add 224.0.0.0/4 dev lo' as root" >&2; exit 1; }

cat > "$TMP/client.py" <<'PY'
import socket, sys, time
port, mode = int(sys.argv[1]), sys.argv[2]
s = socket.socket()
if mode == "never-reads":
    s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
s.connect(("127.0.0.1", port))
s.sendall(b"GET /ws HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
          b"Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n")
head = b""
while b"\r\n\r\n" not in head:
    head += s.recv(1)
if mode == "never-reads":
    time.sleep(1e6)
while s.recv(65536):
    pass
PY

echo "== $(nproc) CPUs, load before: $(cut -d' ' -f1-3 /proc/loadavg); coopdynd at $RATE Hz, $DUR s a run"
printf '%-22s %10s %9s %12s %12s  %s\n' client "ticks/s" overruns "late p50 us" "late p99 us" "viewer /stats"
for client in none reads never-reads; do
  "$BUILD/bin/coopdyn" view --scene "$SCENE" --live --listen 127.0.0.1:0 --lcm-url "$URL" --rate 1000 2> "$TMP/v.err" &
  vpid=$!
  PIDS+=("$vpid")
  port=
  for _ in $(seq 100); do
    port=$(sed -n 's|.*serving http://127.0.0.1:\([0-9]*\)/.*|\1|p' "$TMP/v.err")
    [ -n "$port" ] && break
    sleep 0.05
  done
  [ -n "$port" ] || { cat "$TMP/v.err" >&2; exit 1; }
  if [ "$client" != none ]; then
    python3 "$TMP/client.py" "$port" "$client" &
    PIDS+=("$!")
  fi
  "$BUILD/bin/coopdynd" --scene "$SCENE" --lcm-url "$URL" --rate "$RATE" --duration "$DUR" > "$TMP/d.out" 2> "$TMP/d.err"
  stats=$(curl -s "http://127.0.0.1:$port/stats" | python3 -c \
    'import json,sys; s=json.load(sys.stdin); print("framed %(framed)d sent %(sent)d dropped %(dropped)d clients %(clients)d" % s)')
  for p in "${PIDS[@]}"; do kill "$p" 2>/dev/null || true; wait "$p" 2>/dev/null || true; done
  PIDS=()
  python3 - "$client" "$TMP/d.out" "$stats" <<'PY'
import re, sys
client, d, stats = sys.argv[1], open(sys.argv[2]).read(), sys.argv[3]
m = re.search(r"after (\d+) ticks in ([\d.]+) s: overruns (\d+).*lateness us p50 ([\d.]+) p99 ([\d.]+)", d)
if not m:
    sys.exit("no summary line from coopdynd: " + d)
ticks, secs, over, p50, p99 = int(m[1]), float(m[2]), int(m[3]), m[4], m[5]
print("%-22s %10.1f %9d %12s %12s  %s" % (client, ticks / secs, over, p50, p99, stats))
PY
done
echo "== load after: $(cut -d' ' -f1-3 /proc/loadavg)"
