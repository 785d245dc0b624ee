#!/usr/bin/env bash
# bench/track_quality.sh [BUILD_DIR=build] [DURATION_S=4] [PORT=7791]: the reference controller in
# the loop over udpm (loopback, ttl=0, a private port): coopdynd simulates two_puma_load, `coopdyn
# track` drives the load around a 5 cm circle while squeezing it with 20 N. Prints the share of
# outputs in sync (stepped under one of the controller's last 3 commands) and, on in-sync rows after
# the 1.5 s ramp, the percentiles of the position, orientation and squeeze errors. These depend on how
# the two processes are scheduled (run it on an idle machine; tests check only that the loop closes).
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-build}
duration=${2:-4}
port=${3:-7791}
url="udpm://239.255.76.67:$port?ttl=0"
tmp=$(mktemp -d)
trap 'kill $dpid 2>/dev/null || true; rm -rf "$tmp"' EXIT
"$build/bin/coopdynd" --scene "$here/config/scenes/two_puma_load.yaml" --lcm-url "$url" --duration $((duration + 30)) \
  > "$tmp/daemon.out" 2> "$tmp/daemon.err" &
dpid=$!
"$build/bin/coopdyn" track --scene "$here/config/scenes/two_puma_load.yaml" --lcm-url "$url" --duration "$duration" \
  --squeeze 20 --out "$tmp/track.csv" > "$tmp/track.out"
kill -TERM $dpid; wait $dpid || true
python3 - "$tmp/track.csv" <<'PY'
import csv, sys
rows = [r for r in csv.reader(l for l in open(sys.argv[1]) if not l.startswith('#'))]
head, rows = rows[0], rows[1:]
c = {k: i for i, k in enumerate(head)}
sync = [r for r in rows if r[c['in_sync']] == '1']
late = [r for r in sync if float(r[c['t']]) >= 1.5]
def pct(v, p):
    v = sorted(v); return v[int(p * (len(v) - 1))] if v else float('nan')
pos = [float(r[c['position_error']]) for r in late]
rot = [float(r[c['orientation_error']]) for r in late]
sq = [abs(float(r[c['squeeze']]) - 20.0) for r in late]
print(f"rows {len(rows)}, in sync {len(sync)} ({100.0 * len(sync) / max(1, len(rows)):.1f} %), after the ramp {len(late)}")
print(f"position error m:    p50 {pct(pos, .5):.3g}  p90 {pct(pos, .9):.3g}  max {max(pos, default=float('nan')):.3g}")
print(f"orientation err rad: p50 {pct(rot, .5):.3g}  p90 {pct(rot, .9):.3g}")
print(f"squeeze error N:     p50 {pct(sq, .5):.3g}  p90 {pct(sq, .9):.3g}")
PY
