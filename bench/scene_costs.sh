#!/usr/bin/env bash
# bench/scene_costs.sh [BUILD_DIR=build] [MIN_TIME=0.5] [SCENE.yaml...]: runs `coopdyn bench --json` on
# each scene (default: every shipped scene) and prints the Markdown table of README.md's "Speed"
# section: median CPU time per call and [p10, p90] over 15 repetitions. A scene of your own is
# timed the same way: `coopdyn bench --scene my_scene.yaml`.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-build}
min_time=${2:-0.5}
shift $(( $# > 2 ? 2 : $# )) || true
scenes=("$@")
if [ ${#scenes[@]} -eq 0 ]; then scenes=("$here"/config/scenes/*.yaml); fi
bin="$build/bin/coopdyn"
[ -x "$bin" ] || { echo "scene_costs.sh: $bin not found (build it first)" >&2; exit 1; }
for s in "${scenes[@]}"; do
  "$bin" bench --scene "$s" --min-time "$min_time" --json
done | python3 -c '
import json, sys
dec = json.JSONDecoder()
text = sys.stdin.read()
i, runs = 0, []
while i < len(text):
    while i < len(text) and text[i].isspace(): i += 1
    if i >= len(text): break
    obj, i = dec.raw_decode(text, i)
    runs.append(obj)
cols = ["evaluate", "step:semi_implicit_euler", "step:rk4", "step:rk4+projection", "step:implicit_euler"]
print("| scene (nv, rows) | evaluate | semi-implicit Euler step | RK4 step | RK4 step + projection | implicit Euler step |")
print("|---|---|---|---|---|---|")
for r in runs:
    rows = {x["name"]: x for x in r["rows"]}
    cell = lambda n: ("%.2f us [%.2f, %.2f]" % (rows[n]["median"], rows[n]["p10"], rows[n]["p90"])) if n in rows else ""
    print("| %s (%d, %d) | %s |" % (r["name"], r["nv"], r["constraint_rows"], " | ".join(cell(c) for c in cols)))
'
