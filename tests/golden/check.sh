#!/usr/bin/env bash
# The outputs of outputs.sh, byte for byte against expected/ (see outputs.sh for when they may change).
# Usage: check.sh BIN_DIR
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
bash "$here/outputs.sh" "$1" "$tmp"
if diff -rq "$here/expected" "$tmp" > "$tmp.diff"; then
  echo "$(ls "$tmp" | wc -l) outputs byte-identical to tests/golden/expected"
  rm -f "$tmp.diff"
else
  cat "$tmp.diff"
  for f in $(diff -rq "$here/expected" "$tmp" | awk '/differ$/{print $4}'); do
    diff "$here/expected/$(basename "$f")" "$f" | head -6
  done
  rm -f "$tmp.diff"
  exit 1
fi
