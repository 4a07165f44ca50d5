#!/usr/bin/env bash
# Dart throwing on the host against the device (issue #13): the embedded Cornell box at
# the defaults on the GPU backend, hierarchy only (--bounces 0), `dart_throwing` host and
# device interleaved, 3 runs each. Prints, per run: where, run, seconds of the dart
# throwing, seconds of the whole hierarchy (upload and arrangement on the device
# included), nodes per level. Writes runs.txt beside this script.
# Usage: bash run.sh [BIN]   (default target/release/meshrad)
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
bin=${1:-target/release/meshrad}
out=$(mktemp -d)
for i in 1 2 3; do
  for m in host device; do
    "$bin" solve --backend gpu --bounces 0 --set dart_throwing=$m --out "$out/$m" -q
    python3 - "$out/$m/stats.json" "$m" "$i" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
h = d["hierarchy"]
print(sys.argv[2], sys.argv[3], round(h["seconds_poisson"], 3), round(d["seconds"]["hierarchy"], 3), h["nodes_per_level"], d["gpu"]["device"])
PY
  done
done | tee "$here/runs.txt"
