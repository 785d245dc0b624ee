#!/usr/bin/env bash
# What the robots' meshes cost the viewer page: the time one frame of the 3D view takes to draw (a
# slider step: the frame's poses set, the scene rendered and read back, so the GPU work is counted)
# with the URDF's meshes and with capsules (`coopdyn view --capsules`), in headless Chromium
# (software WebGL, as the tests). Nothing is asserted here: the tests check what is drawn.
#
#   bench/view_mesh_fps.sh [SCENE=pr2_box] [BUILD_DIR=build] [STEPS=60]
#
# 0.5 s of `coopdyn sim --hold` at 1 ms, the page with and without meshes; a script appended to each
# page moves the slider STEPS times and prints the median time of a frame, and frames per second.
set -euo pipefail
cd "$(dirname "$0")/.."
SCENE=${1:-pr2_box}
BUILD=$(cd "${2:-build}" && pwd)
STEPS=${3:-60}
chromium=$(command -v chromium || command -v chromium-browser)
[ -x "$BUILD/bin/coopdyn" ] || { echo "build first: cmake --build $BUILD --target coopdyn" >&2; exit 1; }
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
"$BUILD/bin/coopdyn" sim --scene "config/scenes/$SCENE.yaml" --duration 0.5 --dt 0.001 --hold --out "$tmp/run.csv" 2>/dev/null
"$BUILD/bin/coopdyn" view --scene "config/scenes/$SCENE.yaml" --csv "$tmp/run.csv" --out "$tmp/meshes.html" 2>/dev/null
"$BUILD/bin/coopdyn" view --scene "config/scenes/$SCENE.yaml" --csv "$tmp/run.csv" --out "$tmp/capsules.html" --capsules 2>/dev/null
for page in meshes capsules; do
  python3 - "$tmp/$page.html" "$STEPS" <<'PY'
import sys
p, steps = sys.argv[1], int(sys.argv[2])
s = open(p).read()
timing = """<script>
(function () {  // after the page's own script: STEPS slider steps, each a full frame read back
  var slider = document.getElementById('slider'), gl = document.querySelector('#view canvas').getContext('webgl');
  var px = new Uint8Array(4), ms = [];
  for (var i = 0; i < STEPS; ++i) {
    var t = performance.now();
    slider.value = String(i % (+slider.max + 1)); slider.dispatchEvent(new Event('input'));
    gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, px);
    ms.push(performance.now() - t);
  }
  ms.sort(function (x, y) { return x - y; });
  var pr = JSON.parse(document.getElementById('probe').textContent), med = ms[ms.length >> 1];
  document.title = 'FRAME ' + pr.visuals.triangles + ' triangles, ' + pr.visuals.capsules + ' capsules: ' + med.toFixed(1) +
                   ' ms (median of STEPS), ' + (1000 / med).toFixed(1) + ' frames/s';
})();
</script>
</body>""".replace('STEPS', str(steps))
open(p, 'w').write(s.replace('</body>', timing))
PY
  printf '%s (%s bytes): ' "$page" "$(stat -c %s "$tmp/$page.html")"
  timeout 300 "$chromium" --headless --no-sandbox --disable-gpu --disable-background-networking --disable-component-update \
    --disable-sync --no-first-run --use-angle=swiftshader --enable-unsafe-swiftshader --hide-scrollbars --mute-audio \
    --user-data-dir="$tmp/profile" --window-size=900,600 \
    --dump-dom "file://$tmp/$page.html#paused=1" 2>/dev/null | grep -o 'FRAME [0-9][^<]*' || echo "no result"
done
