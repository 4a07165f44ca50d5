#!/usr/bin/env bash
# GPU links (docs/ALGORITHM.md §5.6) on lavapipe: the embedded Cornell box at its defaults,
# link_memory = 2048 (default) and 0 (trace every bounce), alternating, 3 runs each, in
# one run of this script. Writes links.csv beside it from each run's stats.json.
# Usage: bash experiments/links/lavapipe/run.sh [COMMIT|BINARY]   (from the repository root;
#   default $MESHRAD, else target/release/meshrad; a commit is built by experiments/build-at.sh)
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
bin=$(bash "$here/../../build-at.sh" "${1:-${MESHRAD:-target/release/meshrad}}")
out=$(mktemp -d)
echo "run,link_memory,bounce1,bounces_after,bounces_all,trace,reconstruct,reduce,rays_traced,rays_gathered,linked,traced" >"$here/links.csv"
for i in 1 2 3; do
  for m in 2048 0; do
    "$bin" solve --backend gpu --set link_memory=$m --out "$out/$m" -q
    python3 - "$out/$m/stats.json" "$i" "$m" >>"$here/links.csv" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))["solve"]
b = s["bounces"]
k = dict(s["kernel_seconds"])
l = s.get("links") or {}
print(",".join(str(x) for x in [sys.argv[2], sys.argv[3], round(b[0]["seconds"], 3),
      round(sum(x["seconds"] for x in b[1:]), 3), round(s["seconds_bounces"], 3),
      round(k.get("trace", 0), 3), round(k.get("reconstruct", 0), 3), round(k.get("reduce", 0), 3),
      s["rays_traced"], s["rays_gathered"], l.get("integrals_linked", 0), l.get("integrals_traced", 0)]))
PY
  done
done
cat "$here/links.csv"
