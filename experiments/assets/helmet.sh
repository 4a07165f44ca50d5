#!/usr/bin/env bash
# Issue #34's DamagedHelmet check: the helmet's emission on (emissiveFactor 1 × its
# emissive mask texture) against emission off, under a sky and a sun, on the CPU; the
# mean image brightness of each (EXR, linear), the share of saturated PNG pixels (any
# channel at 255), the emitting triangles, and the wall time.
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
    python3 - "$d" "$tag" "$e" "$(echo "$end - $start" | bc)" <<'P'
import sys, json, numpy as np, OpenEXR, Imath
from PIL import Image
d, tag, e, wall = sys.argv[1:]
f = OpenEXR.InputFile(f"{d}/total.exr"); dw = f.header()['dataWindow']
w, h = dw.max.x - dw.min.x + 1, dw.max.y - dw.min.y + 1
rgb = np.stack([np.frombuffer(f.channel(c, Imath.PixelType(Imath.PixelType.FLOAT)), np.float32) for c in "RGB"], 1)
png = np.asarray(Image.open(f"{d}/total.png").convert("RGB"))
sat = (png.max(axis=2) == 255).mean()
st = json.load(open(f"{d}/stats.json"))
em = st["scene"]["load"]["emitting_triangles"]
print(f"{tag} emission {e}: mean EXR {rgb.mean():.5f}, saturated PNG pixels {100*sat:.2f} %, emitting triangles {em}, wall {float(wall):.1f} s")
P
  done
done | tee -a "$out/results.txt"
