#!/usr/bin/env bash
# Dart throwing on the host against the device (issue #13), on the GPU backend, hierarchy
# only (--bounces 0), `dart_throwing` host and device interleaved, 3 runs each, per scene:
#   cornell   the embedded Cornell box at the defaults;
#   buddha    scenes/shared/cornell_buddha.toml;
#   sponza    scenes/shared/sponza.toml
# (meshes from $MESHRAD_SCENES, default ../shared/scenes). Prints, per run: scene, where,
# run, seconds of the dart throwing, seconds of the whole hierarchy (upload and the
# arrangement on the device included), nodes per level, device; writes runs.txt beside
# this script, and says where the two node sets differ.
# Usage: bash experiments/dart-throwing-device/run.sh [COMMIT|BIN] [scenes...]
#   (default target/release/meshrad cornell; a commit is built by experiments/build-at.sh)
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
bin=$(bash "$here/../build-at.sh" "${1:-target/release/meshrad}")
shift || true
scenes=("$@")
[ ${#scenes[@]} -gt 0 ] || scenes=(cornell)
out=$(mktemp -d)
for scene in "${scenes[@]}"; do
  case "$scene" in
    cornell) args=() ;;
    buddha) args=("$root/scenes/shared/cornell_buddha.toml") ;;
    sponza) args=("$root/scenes/shared/sponza.toml") ;;
    *) echo "unknown scene $scene" >&2; exit 2 ;;
  esac
  for i in 1 2 3; do
    for m in host device; do
      "$bin" solve "${args[@]}" --backend gpu --bounces 0 --set dart_throwing=$m --out "$out/$m" -q \
        --export-nodes "$out/$m.ply"
      python3 - "$out/$m/stats.json" "$scene" "$m" "$i" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
h = d["hierarchy"]
print(sys.argv[2], sys.argv[3], sys.argv[4], round(h["seconds_poisson"], 3), round(d["seconds"]["hierarchy"], 3),
      h["nodes_per_level"], d["gpu"]["device"])
PY
    done
    cmp -s "$out/host.ply" "$out/device.ply" || echo "note: $scene: the device's nodes differ from the host's" >&2
  done
done | tee "$here/runs.txt"
