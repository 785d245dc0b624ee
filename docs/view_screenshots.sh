#!/usr/bin/env bash
# Screenshots of every shipped scene in `coopdyn view` (docs/guide/viewer.md): 1 s of `coopdyn sim`
# (the inputs below; the real robots held still by --hold), the page, and headless Chromium
# (software WebGL) at t = 0.5 s, paused; the
# plot of arm1's end-effector wrench in two_puma_load at 0.7 s; and its +-sigma bands (at the arrows
# and in its plot) under declared torque noise (exaggerated, 20 N m on every joint, so that they
# show at the arrows' scale).
# The PR2 and the TIAGo Pro are drawn with their meshes (the TIAGo Pro's after
# bash config/robots/fetch_meshes.sh). A third argument, scene names separated by commas, makes only
# those scenes' screenshots.
#   bash docs/view_screenshots.sh [build/bin] [docs/views] [SCENE,...]
set -euo pipefail
bin=${1:-build/bin}; out=${2:-docs/views}; only=${3:-}
mkdir -p "$out"
bin=$(cd "$bin" && pwd); out=$(cd "$out" && pwd); here=$(pwd)
chromium=$(command -v chromium || command -v chromium-browser)
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
declare -A torque=(
  [two_wheel_vehicle]="--torque left_spin:pulse:1.0:0:0.5"
  [four_wheel_car]="--torque rl_spin:constant:1100 --torque rr_spin:constant:1100"
  [trike]="--torque rl_spin:constant:150 --torque rr_spin:constant:150"
  [pr2_box]="--hold"
  [tiago_pro_box]="--hold"
)
for f in config/scenes/*.yaml; do
  s=$(basename "$f" .yaml)
  if [ -n "$only" ] && [[ ",$only," != *",$s,"* ]]; then continue; fi
  # shellcheck disable=SC2086
  "$bin/coopdyn" sim --scene "$f" --duration 1 --dt 0.001 ${torque[$s]:-} --out "$tmp/$s.csv" 2>/dev/null
  # the page names its CSV: a relative name, not this machine's temporary folder
  (cd "$tmp" && "$bin/coopdyn" view --scene "$here/$f" --csv "$s.csv" --out "$s.html" > /dev/null 2>&1)
  timeout 120 "$chromium" --headless --no-sandbox --disable-gpu --use-angle=swiftshader --enable-unsafe-swiftshader \
    --hide-scrollbars --mute-audio --no-first-run --user-data-dir="$tmp/profile" --window-size=900,600 \
    --virtual-time-budget=3000 --screenshot="$out/view_$s.png" "file://$tmp/$s.html#t=0.5&paused=1" 2>/dev/null
  echo "$out/view_$s.png"
done
[ -z "$only" ] || exit 0
# the plot of a selected wrench: arm1's end-effector wrench of the falling arms (docs/guide/viewer.md)
timeout 120 "$chromium" --headless --no-sandbox --disable-gpu --use-angle=swiftshader --enable-unsafe-swiftshader \
  --hide-scrollbars --mute-audio --no-first-run --user-data-dir="$tmp/profile" --window-size=1100,600 \
  --virtual-time-budget=3000 --screenshot="$out/view_two_puma_load_plot.png" \
  "file://$tmp/two_puma_load.html#t=0.7&paused=1&wrench=arm1.ee" 2>/dev/null
echo "$out/view_two_puma_load_plot.png"
# the uncertainty bands: two_puma_load with declared torque noise (docs/guide/viewer.md "Uncertainty")
sed "s|file: ../robots/|file: $here/config/robots/|" config/scenes/two_puma_load.yaml > "$tmp/noisy.yaml"
printf '\nnoise: {tau: 20}\n' >> "$tmp/noisy.yaml"
"$bin/coopdyn" sim --scene "$tmp/noisy.yaml" --duration 1 --dt 0.001 --out "$tmp/noisy.csv" 2>/dev/null
(cd "$tmp" && "$bin/coopdyn" view --scene noisy.yaml --csv noisy.csv --out noisy.html > /dev/null 2>&1)
timeout 120 "$chromium" --headless --no-sandbox --disable-gpu --use-angle=swiftshader --enable-unsafe-swiftshader \
  --hide-scrollbars --mute-audio --no-first-run --user-data-dir="$tmp/profile" --window-size=1100,600 \
  --virtual-time-budget=3000 --screenshot="$out/view_two_puma_load_sigma.png" "file://$tmp/noisy.html#t=0.7&paused=1&wrench=arm1.ee" 2>/dev/null
echo "$out/view_two_puma_load_sigma.png"
