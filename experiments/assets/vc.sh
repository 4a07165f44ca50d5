#!/usr/bin/env bash
# Issue #34: Khronos' VC (a city inside a skybox mesh, 234 unnamed nodes) as shipped, under
# a sun and a constant sky, then with the node the warning names left out. Prints the
# warnings and notes and the total image's mean (1 spp: the point is whether light gets in).
# Usage (from the repository root): bash experiments/assets/vc.sh VC.glb OUT_DIR BIN
# (VC.glb: `bash scenes/fetch.sh VC`, or glTF-Sample-Models 2.0/VC/glTF-Binary/VC.glb)
set -euo pipefail
[ $# -ge 3 ] || { sed -n '2,6p' "$0" >&2; exit 2; }
glb=$(cd "$(dirname "$1")" && pwd)/$(basename "$1") out=$2 bin=$3
mkdir -p "$out"
scene() { # GROUP-LINE
  printf '[[object]]\nmesh = "%s"\n%s\n\n[[light]]\ntype = "directional"\ndirection = [0.3, -1.0, 0.2]\nirradiance = [3.0, 3.0, 3.0]\n\n[sky]\nradiance = [0.3, 0.35, 0.5]\n' "$glb" "$1"
}
run() { # LABEL GROUP-LINE
  scene "$2" >"$out/$1.toml"
  echo "== $1: $bin solve $out/$1.toml --backend cpu --set levels=4 --set sender_level=3 --spp 1"
  "$bin" solve "$out/$1.toml" --out "$out/$1" --backend cpu --set levels=4 --set sender_level=3 --spp 1 -q 2>&1 |
    cut -c1-400
  python3 -c 'import json,sys; s=json.load(open(sys.argv[1])); print("image warnings:", len(s["image"]["warnings"]), "| nodes lit per light:", s["solve"]["nodes_lit_per_light"])' "$out/$1/stats.json"
  python3 - "$out/$1/total.exr" <<'PY'
import sys, OpenEXR, Imath, numpy as np
f = OpenEXR.InputFile(sys.argv[1])
c = [np.frombuffer(f.channel(k, Imath.PixelType(Imath.PixelType.FLOAT)), dtype=np.float32) for k in "RGB"]
m = np.maximum(np.maximum(c[0], c[1]), c[2])
print(f"total image: mean {m.mean():.3e}, pixels above 0: {100 * (m > 0).mean():.1f} %")
PY
}
run as-shipped ""
run without-skybox 'group = "!nodes[19]"'
