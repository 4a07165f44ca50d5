#!/usr/bin/env bash
# Issue #33: the image's indirect error with the basis read, a final gather at the pixel
# samples whose read is doubted (`doubt_gather`, `doubt_nodes`, `doubt_spread`), and the
# brute-force gather at every sample (`final_gather_pixels`), against two independent
# references (experiments/images/image_error.py), with the output phase's time.
# Usage (from the repository root):
#   bash experiments/images/doubt/run.sh SCENE REF_DIR_A REF_DIR_B OUT_DIR BIN [LABEL=SETTINGS ...]
# SETTINGS are `--set` pairs joined by commas, e.g. `g16=doubt_gather=16,doubt_nodes=4`;
# `basis=` is the defaults. Prints, per label: the output phase's seconds (`--stats`), the
# doubted share of the samples, and the errors of indirect.exr and total.exr.
set -euo pipefail
[ $# -ge 6 ] || { sed -n '2,10p' "$0" >&2; exit 2; }
scene=$1 ra=$2 rb=$3 out=$4 bin=$5; shift 5
here=$(cd "$(dirname "$0")/.." && pwd)
mkdir -p "$out"
for spec in "$@"; do
  label=${spec%%=*} settings=${spec#*=}
  set=(); IFS=, read -ra kv <<<"$settings"; for s in "${kv[@]}"; do [ -n "$s" ] && set+=(--set "$s"); done
  "$bin" solve "$scene" --backend cpu --out "$out/$label" --stats "${set[@]}" -q 2>"$out/$label.log"
  secs=$(grep -o 'output [0-9.]* s' "$out/$label.log" | head -1)
  share=$(python3 -c "import json; i=json.load(open('$out/$label/stats.json'))['image']; d=i.get('doubted_samples',0); b=i.get('basis_samples',0); print(f'doubted {d/(d+b)*100:.1f} %' if d+b else 'doubted -')")
  echo "$label ($settings): $secs, $share"
  python3 "$here/image_error.py" "$ra/indirect.exr" "$rb/indirect.exr" "$out/$label/indirect.exr" | sed 's/^/  indirect /'
  python3 "$here/image_error.py" "$ra/total.exr" "$rb/total.exr" "$out/$label/total.exr" | tail -n +2 | sed 's/^/  total /'
done
