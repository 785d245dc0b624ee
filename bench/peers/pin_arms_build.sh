#!/bin/bash
# Builds bench/peers/pin_arms.cc (coopdyn against Pinocchio on the arms-on-one-load scenes)
# in a scratch folder outside the repository; nothing here is part of coopdyn's build:
#   bench/peers/pin_arms_build.sh SCRATCH_DIR PINOCCHIO_GIT_DIR [COOPDYN_GIT_DIR] [COOPDYN_COMMIT]
#   taskset -c 1 SCRATCH_DIR/pin_arms 21
# PINOCCHIO_GIT_DIR: a git (or bare) clone of github.com/stack-of-tasks/pinocchio
# COOPDYN_GIT_DIR:   the coopdyn repository, only read with `git archive` (default: this one)
# COOPDYN_COMMIT:    default HEAD
# Steps: 1. `git archive` both sources into SCRATCH_DIR/pinocchio-src and coopdyn-src;
#        2. Pinocchio used header-only (no CMake, no library): the three headers its CMake would generate
#           (config.hpp, deprecated.hpp, warning.hpp) are written into gen/pinocchio/; no python, no
#           collision (hpp-fcl), no urdf: the models are built from coopdyn's Model in pin_arms.cc;
#        3. coopdyn's core + scene + text libraries compiled from the snapshot with coopdyn's own Release
#           flags (-O3 -DNDEBUG -march=native, C++17), as object files in obj/;
#        4. pin_arms.cc compiled with the same flags and linked.
# Needs libboost-dev (Pinocchio's headers) besides coopdyn's own build dependencies.
# Builds run under nice with at most 2 jobs.
set -euo pipefail
SCRATCH=${1:?usage: pin_arms_build.sh SCRATCH_DIR PINOCCHIO_GIT_DIR [COOPDYN_GIT_DIR] [COOPDYN_COMMIT]}
PEERS=$(cd "$(dirname "$0")" && pwd)
PIN_GIT=${2:?usage: pin_arms_build.sh SCRATCH_DIR PINOCCHIO_GIT_DIR [COOPDYN_GIT_DIR] [COOPDYN_COMMIT] (a clone of github.com/stack-of-tasks/pinocchio)}
COOP_GIT=${3:-$(cd "$PEERS/../.." && pwd)}
COOP_REV=${4:-HEAD}
mkdir -p "$SCRATCH"
HERE=$(cd "$SCRATCH" && pwd)
case "$HERE/" in "$COOP_GIT"/*) echo "pin_arms_build.sh: SCRATCH_DIR must be outside the repository ($COOP_GIT)" >&2; exit 2;; esac
cp "$PEERS/pin_arms.cc" "$HERE/"
cd "$HERE"
FLAGS="-std=c++17 -O3 -DNDEBUG -march=native"
CXX=${CXX:-g++}

rm -rf pinocchio-src coopdyn-src gen obj
mkdir -p pinocchio-src coopdyn-src gen/pinocchio gen/service obj
git -C "$PIN_GIT" archive HEAD | tar -x -C pinocchio-src
git -C "$PIN_GIT" rev-parse HEAD > pinocchio-src/COMMIT
git -C "$COOP_GIT" archive "$COOP_REV" | tar -x -C coopdyn-src
git -C "$COOP_GIT" rev-parse "$COOP_REV" > coopdyn-src/COMMIT

# --- Pinocchio: the generated headers, by hand (what jrl-cmakemodules would write) ---
. "$PEERS/pin_headers.sh"
write_pinocchio_headers pinocchio-src gen

# --- coopdyn: the libraries the scene loader and the evaluation need ---
CV=$(sed -n 's/^project(coopdyn VERSION \([0-9.]*\).*/\1/p' coopdyn-src/CMakeLists.txt)
IFS=. read -r CMAJ CMIN CPAT <<< "$CV"
sed -e "s/@PROJECT_VERSION@/$CV/" -e "s/@PROJECT_VERSION_MAJOR@/$CMAJ/" -e "s/@PROJECT_VERSION_MINOR@/$CMIN/" \
    -e "s/@PROJECT_VERSION_PATCH@/$CPAT/" coopdyn-src/service/version.h.in > gen/service/version.h
SRCS=$(cd coopdyn-src && ls service/model/*.cc service/algorithms/*.cc service/constraints/*.cc service/dynamics/*.cc \
       service/scene/*.cc service/text/*.cc)
URDF_CFLAGS=$(pkg-config --cflags urdfdom)
printf '%s\n' $SRCS | nice -n 10 xargs -P 2 -I{} sh -c \
  'o=obj/$(echo {} | tr / _ | sed "s/\.cc$/.o/"); '"$CXX $FLAGS -Wall -Wno-unused-parameter -Icoopdyn-src -Igen -I/usr/include/eigen3 $URDF_CFLAGS"' -c coopdyn-src/{} -o $o'

# --- pin_arms ---
nice -n 10 $CXX $FLAGS -DCOOPDYN_SOURCE_DIR="\"$HERE/coopdyn-src\"" \
  -Igen -Ipinocchio-src/include -Icoopdyn-src -I/usr/include/eigen3 \
  -c pin_arms.cc -o obj/pin_arms.o
$CXX $FLAGS obj/*.o -o pin_arms $(pkg-config --libs urdfdom yaml-cpp) -lpthread
PV=$(sed -n 's:.*<version>\(.*\)</version>.*:\1:p' pinocchio-src/package.xml)
echo "built $HERE/pin_arms (Pinocchio $PV $(cat pinocchio-src/COMMIT), coopdyn $(cat coopdyn-src/COMMIT))"
