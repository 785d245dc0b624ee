#!/usr/bin/env bash
# Functions longer than LIMIT lines (default 100) in service/ and clients/, longest first; exit 1 if
# there is one. Needs Universal Ctags (Debian: universal-ctags).
# Usage: .ci/long_functions.sh [LIMIT]
set -euo pipefail
cd "$(dirname "$0")/.."
limit=${1:-100}
ctags -R --languages=C++ --kinds-C++=f --fields=+ne -f - service clients |
  awk -F'\t' -v limit="$limit" '{n = ""; e = ""
    for (i = 4; i <= NF; i++) { if ($i ~ /^line:/) n = substr($i, 6); if ($i ~ /^end:/) e = substr($i, 5) }
    if (e != "" && e - n + 1 > limit) print e - n + 1, $2 ":" n, $1}' | sort -rn > /tmp/long_functions.$$
cat /tmp/long_functions.$$
count=$(wc -l < /tmp/long_functions.$$); rm -f /tmp/long_functions.$$
[ "$count" -eq 0 ] || { echo "$count functions over $limit lines"; exit 1; }
