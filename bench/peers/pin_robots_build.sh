#!/bin/bash
# Builds bench/peers/pin_robots.cc (the Pinocchio reference for scenes of whole robots holding a load)
# in a scratch folder outside the repository; nothing here is part of coopdyn's build:
#   bench/peers/pin_robots_build.sh SCRATCH_DIR PINOCCHIO_GIT_DIR
#   bench/peers/pin_robots_compare.py --peer bench/peers/pin_robots/SCENE.json --pin SCRATCH_DIR/pin_robots
# PINOCCHIO_GIT_DIR: a git (or bare) clone of github.com/stack-of-tasks/pinocchio
# Steps: 1. `git archive` Pinocchio into SCRATCH_DIR/pinocchio-src;
#        2. Pinocchio header-only, as pin_arms_build.sh (config.hpp, parsers/config.hpp, deprecated.hpp,
#           warning.hpp written into gen/pinocchio/), plus its URDF parser: src/parsers/urdf/model.cpp and
#           utils.cpp compiled with -DPINOCCHIO_WITH_URDFDOM against Debian's urdfdom
#           (geometry.cpp, which needs hpp-fcl, is left out: no geometry is read);
#        3. pin_robots.cc compiled (it includes nothing of coopdyn) and linked with urdfdom.
# Needs libboost-dev, libeigen3-dev and liburdfdom-dev (coopdyn's own build dependencies but Boost).
# Builds run under nice with at most 2 jobs.
set -euo pipefail
SCRATCH=${1:?usage: pin_robots_build.sh SCRATCH_DIR PINOCCHIO_GIT_DIR}
PEERS=$(cd "$(dirname "$0")" && pwd)
PIN_GIT=${2:?usage: pin_robots_build.sh SCRATCH_DIR PINOCCHIO_GIT_DIR (a clone of github.com/stack-of-tasks/pinocchio)}
REPO=$(cd "$PEERS/../.." && pwd)
mkdir -p "$SCRATCH"
HERE=$(cd "$SCRATCH" && pwd)
case "$HERE/" in "$REPO"/*) echo "pin_robots_build.sh: SCRATCH_DIR must be outside the repository ($REPO)" >&2; exit 2;; esac
cp "$PEERS/pin_robots.cc" "$HERE/"
cd "$HERE"
FLAGS="-std=c++17 -O2 -DNDEBUG -DPINOCCHIO_WITH_URDFDOM"
CXX=${CXX:-g++}

rm -rf pinocchio-src gen obj
mkdir -p pinocchio-src gen/pinocchio obj
git -C "$PIN_GIT" archive HEAD | tar -x -C pinocchio-src
git -C "$PIN_GIT" rev-parse HEAD > pinocchio-src/COMMIT

. "$PEERS/pin_headers.sh"
write_pinocchio_headers pinocchio-src gen

INC="-Igen -Ipinocchio-src/include -I/usr/include/eigen3 $(pkg-config --cflags urdfdom)"
printf '%s\n' pinocchio-src/src/parsers/urdf/model.cpp pinocchio-src/src/parsers/urdf/utils.cpp pin_robots.cc | \
  nice -n 10 xargs -P 2 -I{} sh -c "$CXX $FLAGS $INC -w -c {} -o obj/\$(basename {} | sed 's/\.c[cp]*$/.o/')"
$CXX $FLAGS obj/*.o -o pin_robots $(pkg-config --libs urdfdom)
echo "built $HERE/pin_robots (Pinocchio $PV $(cat pinocchio-src/COMMIT))"
