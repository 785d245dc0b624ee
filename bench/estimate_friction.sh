#!/bin/bash
# Estimate mode with joint friction and torque noise, end to end: coopdyn sim runs two PUMAs with
# damping and Coulomb friction on every joint (bench/scenes/two_puma_friction.yaml), their torques
# get the scene's declared noise (0.5 N m, seeded), coopdyn send --states replays them to coopdynd
# --mode estimate twice (joint losses compensated, the default; and estimate.compensate_joint_losses
# false), lcm-logger records each, coopdyn log converts, docs/plot_estimate_friction.py plots the
# estimated wrench, its band and the true one (docs/estimate_friction_two_puma.png).
#   bash bench/estimate_friction.sh [BUILD_BIN] [OUT.png] [WRENCH.COMPONENT]
# Loopback multicast only (ttl=0), on a port of its own.
set -euo pipefail
cd "$(dirname "$0")/.."
bin=${1:-build/bin}
png=${2:-docs/estimate_friction_two_puma.png}
col=${3:-arm1.ee.fz}
scene=bench/scenes/two_puma_friction.yaml
url="udpm://239.255.76.67:7679?ttl=0"
tmp=$(mktemp -d)
[ -n "${KEEP:-}" ] && echo "keeping $tmp" || trap 'rm -rf "$tmp"' EXIT

"$bin/coopdyn" sim --scene $scene --duration 0.6 --dt 0.001 --every 10 --hold \
  --torque arm1.q1:pulse:45:0.1:0.3 --torque arm2.q2:pulse:-40:0.1:0.25 --out "$tmp/sim.csv"
python3 - "$tmp/sim.csv" "$tmp/noisy.csv" <<'PY'
import random, sys
src, dst = sys.argv[1], sys.argv[2]
rng = random.Random(28)
with open(src) as f, open(dst, "w") as g:
    line = f.readline()
    while line.startswith("#"):
        g.write(line)
        line = f.readline()
    head = line.rstrip("\n").split(",")
    g.write(line)
    noisy = [i for i, h in enumerate(head) if h.startswith("tau:arm")]
    for line in f:
        cells = line.rstrip("\n").split(",")
        for i in noisy:
            cells[i] = repr(float(cells[i]) + rng.gauss(0.0, 0.5))
        g.write(",".join(cells) + "\n")
PY

replay() {  # replay DIR [CONFIG]
  local dir=$1 cfg=()
  mkdir -p "$tmp/$dir"
  if [ $# -gt 1 ]; then printf '%s\n' "$2" > "$tmp/$dir.yaml"; cfg=(--config "$tmp/$dir.yaml"); fi
  lcm-logger --lcm-url="$url" -q "$tmp/$dir.lcmlog" & local logger=$!
  "$bin/coopdynd" --scene $scene --mode estimate --trigger arrival --lcm-url "$url" --duration 60 "${cfg[@]}" \
    > "$tmp/$dir.daemon.log" 2>&1 & local daemon=$!
  sleep 1
  "$bin/coopdyn" send --scene $scene --states "$tmp/noisy.csv" --rate 100 --lcm-url "$url" > /dev/null
  sleep 0.5
  kill -TERM $daemon; wait $daemon || true
  kill -INT $logger; wait $logger || true
  "$bin/coopdyn" log --in "$tmp/$dir.lcmlog" --out "$tmp/$dir" --scene $scene --no-plot > /dev/null
}
replay comp
replay raw "estimate: {compensate_joint_losses: false}"
py=${PYTHON:-python3}  # the Python that plots: one with matplotlib
$py -c 'import matplotlib' 2>/dev/null || py=/usr/bin/python3
PYTHONPATH=docs $py docs/plot_estimate_friction.py "$tmp/sim.csv" "$tmp/comp/COOPDYN_OUTPUT.csv" \
  "$tmp/raw/COOPDYN_OUTPUT.csv" "$png" "$col"
