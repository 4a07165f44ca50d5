#!/usr/bin/env bash
# Issue #34's DamagedHelmet check: the helmet's emission on (emissiveFactor 1 × its
# emissive mask texture) against emission off, under a sky and a sun, on the CPU; the
# mean image brightness of each (EXR, linear), the share of pixels that are white at
# --exposure 0 and of saturated PNG pixels, the emitting triangles, and the wall time
# (image_stats.py).
# Usage: bash experiments/assets/helmet.sh HELMET.glb OUT_DIR BIN|COMMIT...
# HELMET.glb: Khronos' DamagedHelmet (CC-BY 4.0; `scenes/fetch.sh` names where to get it).
set -euo pipefail
[ $# -ge 3 ] || { echo "usage: helmet.sh HELMET.glb OUT_DIR BIN|COMMIT..." >&2; exit 2; }
glb=$(cd "$(dirname "$1")" && pwd)/$(basename "$1"); out=$2; shift 2
mkdir -p "$out"; cp "$glb" "$out/helmet.glb"
for e in on off; do
  flag=""; [ $e = off ] && flag="emission = false"
  cat > "$out/helmet_$e.toml" <<T
# DamagedHelmet under a sky and a sun; emission $e.
[[object]]
mesh = "helmet.glb"
$flag

[sky]
radiance = [0.3, 0.3, 0.3]

[[light]]
type = "directional"
direction = [-0.4, -1.0, -0.6]
irradiance = [3.0, 3.0, 3.0]

[camera]
position = [0.0, 0.3, 3.2]
target = [0.0, 0.0, 0.0]
fov = 45.0
width = 256
height = 256
T
done
root=$(cd "$(dirname "$0")/../.." && pwd)
for b in "$@"; do
  bin=$(bash "$root/experiments/build-at.sh" "$b")
  tag=$(basename "$bin")
  for e in on off; do
    d="$out/$tag-$e"
    start=$(date +%s.%N)
    "$bin" solve "$out/helmet_$e.toml" --backend cpu --out "$d" > "$d.log" 2>&1 || { echo "$tag $e failed: see $d.log"; continue; }
    end=$(date +%s.%N)
    python3 "$root/experiments/assets/image_stats.py" "$d" "$tag emission $e" "$(echo "$end - $start" | bc)"
  done
done | tee -a "$out/results.txt"
