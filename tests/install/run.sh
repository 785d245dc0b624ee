#!/usr/bin/env bash
# ctest install.find_package_and_pkg_config: `cmake --install` of this build into a temporary
# prefix; the installed binaries run on the installed scene; then a user's program (client.cc) is
# built against the installed package twice, with find_package(coopdyn CONFIG) (CMakeLists.txt here)
# and with pkg-config --cflags --libs coopdyn, and each build runs and checks the physics.
# Offline; about 30-60 s (two compiles of client.cc).
# The installed Python package (generated types and log reader) is imported and used by PYTHON.
# usage: run.sh BUILD_DIR CMAKE CXX LIBDIR [PYTHON PYTHON_DIR]
set -euo pipefail
build=$1 cmake=$2 cxx=$3 libdir=$4 python=${5:-} pydir=${6:-}
src=$(cd "$(dirname "$0")" && pwd)
work=$(mktemp -d "${TMPDIR:-/tmp}/coopdyn-install-test.XXXXXX")
trap 'rm -rf "$work"' EXIT
prefix=$work/prefix
fail() { echo "FAILED: $*"; exit 1; }
quiet() { "$@" > "$work/step.log" 2>&1 || { cat "$work/step.log"; fail "$*"; }; }

echo "== cmake --install $build --prefix $prefix"
quiet "$cmake" --install "$build" --prefix "$prefix"
for f in bin/coopdyn bin/coopdynd "$libdir"/libcoopdyn_core.a "$libdir"/libcoopdyn_scene.a "$libdir"/libcoopdyn_runtime.a \
         include/coopdyn/service/scene/scene.h include/coopdyn/service/version.h \
         include/coopdyn/clients/cooperative_controller.h include/coopdyn/coopdyn/output_t.hpp \
         share/coopdyn/coopdynd.yaml share/coopdyn/scenes/two_puma_load.yaml share/coopdyn/robots/puma560.yaml \
         "$libdir"/cmake/coopdyn/coopdynConfig.cmake "$libdir"/cmake/coopdyn/coopdynConfigVersion.cmake \
         "$libdir"/pkgconfig/coopdyn.pc; do
  [ -e "$prefix/$f" ] || fail "$f not installed"
done
scene=$prefix/share/coopdyn/scenes/two_puma_load.yaml

echo "== the installed binaries"
"$prefix/bin/coopdyn" --version
"$prefix/bin/coopdynd" --version
"$prefix/bin/coopdyn" eval --scene "$scene" > "$work/eval.json" || fail "installed coopdyn eval on the installed scene"
grep -q '"status": "ok"' "$work/eval.json" || fail "installed coopdyn eval: status not ok"

if [ -n "$python" ]; then
  echo "== the installed Python package ($pydir)"
  for f in "$pydir"/coopdyn/__init__.py "$pydir"/coopdyn/output_t.py "$pydir"/coopdyn/lcmlog.py \
           share/coopdyn/examples/python/log_wrenches.py share/coopdyn/examples/python/live_client.py; do
    [ -e "$prefix/$f" ] || fail "$f not installed"
  done
  # a message through the installed types and the installed log reader, with nothing but the prefix on the path
  PYTHONPATH=$prefix/$pydir "$python" -B -c '
import io, sys, coopdyn
from coopdyn import lcmlog
assert coopdyn.__file__.startswith(sys.argv[1]), coopdyn.__file__
m = coopdyn.torque_command_t(); m.num_names, m.names, m.num_torques, m.tau = 1, ["arm1.q2"], 1, [0.1]
f = io.BytesIO(); lcmlog.write(f, [(0, 1, "COOPDYN_COMMAND", m.encode())])
open(sys.argv[2], "wb").write(f.getvalue())
(e,) = lcmlog.read(sys.argv[2])
d = lcmlog.decode(e.data)
assert (list(d.names), list(d.tau)) == (["arm1.q2"], [0.1]), (d.names, d.tau)
print("coopdyn package:", coopdyn.__file__)' "$prefix/$pydir" "$work/one.lcmlog" || fail "the installed Python package"
fi

echo "== find_package(coopdyn CONFIG): configure, build, run"
quiet "$cmake" -S "$src" -B "$work/client" -DCMAKE_PREFIX_PATH="$prefix" -DCMAKE_CXX_COMPILER="$cxx"
quiet "$cmake" --build "$work/client"
"$work/client/client" | tee "$work/client.out" || fail "the find_package client"
grep -qxF "scene $scene" "$work/client.out" || fail "the find_package client did not load the installed scene"

echo "== pkg-config --cflags --libs coopdyn: build, run"
export PKG_CONFIG_PATH=$prefix/$libdir/pkgconfig
flags=$(pkg-config --cflags --libs coopdyn) || fail "pkg-config coopdyn"
echo "$flags"
data=$(pkg-config --variable=datadir coopdyn)
[ "$(cd "$data" && pwd)" = "$prefix/share/coopdyn" ] || fail "the .pc file's datadir $data is not $prefix/share/coopdyn"
# shellcheck disable=SC2086
quiet "$cxx" -std=c++17 "$src/client.cc" -o "$work/client_pc" -DCOOPDYN_INSTALLED_DATA_DIR="\"$data\"" $flags
"$work/client_pc" | tee "$work/client_pc.out" || fail "the pkg-config client"
echo "== installed package OK"
