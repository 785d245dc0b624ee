#!/usr/bin/env bash
# Writes what coopdyn prints for a fixed set of runs on the shipped scenes into OUT_DIR: `coopdyn eval`
# JSON, `coopdyn sim` per-step CSV, and the CSVs `coopdyn log` makes of a recorded daemon log
# (two_puma_load.lcmlog: coopdynd at 50 Hz, five torque commands from coopdyn send). check.sh
# compares them with expected/ (compare.py); after a change that is meant to change an output,
#   bash tests/golden/outputs.sh build/bin tests/golden/expected
# and say in the commit why the outputs changed.
# Usage: outputs.sh BIN_DIR OUT_DIR
set -euo pipefail
bin=$(cd "$1" && pwd)
mkdir -p "$2"
out=$(cd "$2" && pwd)
here=$(cd "$(dirname "$0")" && pwd)
cd "$here/../.."   # scene paths relative to the source tree, as a user types them
rm -f "$out"/*.json "$out"/*.csv "$out"/*.txt
for scene in config/scenes/*.yaml; do
  name=$(basename "$scene" .yaml)
  "$bin/coopdyn" eval --scene "$scene" > "$out/eval.$name.json" || echo "exit $?" >> "$out/eval.$name.json"
  "$bin/coopdyn" sim --scene "$scene" --duration 0.01 --dt 0.001 > "$out/sim.$name.csv" \
    || echo "exit $?" >> "$out/sim.$name.csv"
done
for f in classic pseudo_joint svd; do
  "$bin/coopdyn" eval --scene config/scenes/two_puma_load.yaml --formulation $f > "$out/eval.two_puma_load.$f.json"
  "$bin/coopdyn" sim --scene config/scenes/two_puma_load.yaml --formulation $f --duration 0.01 --dt 0.001 \
    --torque arm1.q1:constant:1.0 > "$out/sim.two_puma_load.$f.csv"
done
for i in semi_implicit_euler implicit_euler; do
  "$bin/coopdyn" sim --scene config/scenes/two_puma_load.yaml --integrator $i --duration 0.01 --dt 0.001 \
    --torque arm1.q1:pulse:1.0:0.002:0.006 --every 2 > "$out/sim.two_puma_load.$i.csv"
done
"$bin/coopdyn" sim --scene config/scenes/four_wheel_car.yaml --duration 0.02 --dt 0.001 \
  --torque rl_spin:constant:20 --torque rr_spin:constant:20 --steer fl_steer:ramp:0.02:0:0.02 \
  --steer fr_steer:ramp:0.02:0:0.02 > "$out/sim.four_wheel_car.drive.csv"
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
(cd "$tmp" && "$bin/coopdyn" log --in "$here/two_puma_load.lcmlog" --out log --no-plot > table.txt)
cp "$tmp/table.txt" "$out/log.table.txt"
for f in "$tmp"/log/*.csv; do cp "$f" "$out/log.$(basename "$f")"; done
