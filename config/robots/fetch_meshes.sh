#!/usr/bin/env bash
# Puts the TIAGo Pro's meshes (and the PR2's, which are shipped) where coopdyn view finds them:
# config/robots/example-robot-data/robots/<robot>_description/meshes/, from Gepetto/example-robot-data
# at the commit the URDFs were taken from (about 8 MB; git and network needed). Their licence is the
# source repository's (robots/tiago_pro_description/README.md: CC-BY-NC-ND 3.0).
# usage: bash config/robots/fetch_meshes.sh [REPOSITORY_URL_OR_CLONE]
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
src="${1:-https://github.com/Gepetto/example-robot-data}"
commit=39aa94379908fa743da90b21dc9e1fb8308f746b
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
git -C "$tmp" init -q
git -C "$tmp" remote add origin "$src"
git -C "$tmp" fetch -q --depth 1 origin "$commit"
for d in robots/tiago_pro_description/meshes robots/tiago_pro_description/README.md robots/pr2_description/meshes; do
  mkdir -p "$here/example-robot-data/$(dirname "$d")"
  git -C "$tmp" archive FETCH_HEAD "$d" | tar -x -C "$here/example-robot-data"
done
echo "meshes in $here/example-robot-data/robots/ (tiago_pro_description, pr2_description)"
