#!/usr/bin/env bash
# The outputs of outputs.sh against expected/: the same text, the same numbers to 1e-7 (compare.py says
# why not bytes, and counts the files that are byte-identical).
# Usage: check.sh BIN_DIR [PYTHON]
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
bash "$here/outputs.sh" "$1" "$tmp"
"${2:-python3}" "$here/compare.py" "$here/expected" "$tmp"
