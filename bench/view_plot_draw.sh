#!/usr/bin/env bash
# What the plot's +-sigma bands cost the viewer page: the time one redraw of the page takes (the plot
# drawn again from the frames, and the 3D view) with the bands shown and hidden, in headless
# Chromium (software WebGL). Nothing is asserted here: the tests check what is drawn.
#
#   bench/view_plot_draw.sh [FRAMES=2000] [BUILD_DIR=build]
#
# two_puma_load with declared torque noise (noise: {tau: 20}), `coopdyn sim` of 1 s at 1/FRAMES s,
# `coopdyn view` (at most FRAMES frames), arm1.ee's plot at t = 0.7 s; a script appended to the page
# toggles the bands checkbox 40 times (each a full redraw) and prints the median of each state.
set -euo pipefail
cd "$(dirname "$0")/.."
FRAMES=${1:-2000}
BUILD=$(cd "${2:-build}" && pwd)
here=$(pwd)
chromium=$(command -v chromium || command -v chromium-browser)
[ -x "$BUILD/bin/coopdyn" ] || { echo "build first: cmake --build $BUILD --target coopdyn" >&2; exit 1; }
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
sed "s|file: ../robots/|file: $here/config/robots/|" config/scenes/two_puma_load.yaml > "$tmp/noisy.yaml"
printf '\nnoise: {tau: 20}\n' >> "$tmp/noisy.yaml"
dt=$(python3 -c "print(1 / $FRAMES)")
"$BUILD/bin/coopdyn" sim --scene "$tmp/noisy.yaml" --duration 1 --dt "$dt" --out "$tmp/noisy.csv" 2>/dev/null
"$BUILD/bin/coopdyn" view --scene "$tmp/noisy.yaml" --csv "$tmp/noisy.csv" --out "$tmp/page.html" --max-frames "$FRAMES" > /dev/null 2>&1
python3 - "$tmp/page.html" <<'PY'
import sys
p = sys.argv[1]
s = open(p).read()
timing = """<script>
(function () {  // after the page's own script: 40 redraws, alternately with and without the bands
  var box = document.getElementById('bands'), on = [], off = [];
  for (var i = 0; i < 40; ++i) {
    var t = performance.now();
    box.checked = !box.checked; box.dispatchEvent(new Event('change'));
    (box.checked ? on : off).push(performance.now() - t);
  }
  var med = function (a) { a.sort(function (x, y) { return x - y; }); return a[a.length >> 1].toFixed(1); };
  document.title = 'REDRAW ' + JSON.parse(document.getElementById('probe').textContent).frames + ' frames: bands shown ' +
                   med(on) + ' ms, hidden ' + med(off) + ' ms (median of 20 each)';
})();
</script>
</body>"""
open(p, 'w').write(s.replace('</body>', timing))
PY
timeout 120 "$chromium" --headless --no-sandbox --disable-gpu --use-angle=swiftshader --enable-unsafe-swiftshader \
  --hide-scrollbars --mute-audio --no-first-run --user-data-dir="$tmp/profile" --window-size=1100,600 \
  --dump-dom "file://$tmp/page.html#t=0.7&paused=1&wrench=arm1.ee" 2>/dev/null | grep -o 'REDRAW [0-9][^<]*'
