#!/usr/bin/env bash
# Issue #32, step 1: every scene's error at the 256 area-uniform points of its cached
# converged reference, per stratum (points lit only indirectly, lit points; the worse is
# the headline), CPU backend, defaults: `meshrad probe` (final gather) and, with
# `--set final_gather=0`, the basis read that images show. Errors by
# experiments/area-accuracy/errors_at_points.py. Sponza's meshes come from
# $MESHRAD_SCENES (default ../shared/scenes).
# Usage: bash experiments/strata/run.sh BIN|COMMIT [OUT_DIR] [SCENES...]
#   (from the repository root; SCENES: cornell cornell_area cornell_buddha sponza, all by
#   default; writes OUT_DIR/errors.txt, OUT_DIR by default experiments/strata/<label>)
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
[ $# -ge 1 ] || { sed -n '2,10p' "$0" >&2; exit 2; }
label() { git rev-parse -q --verify --short "$1^{commit}" 2>/dev/null || basename "$1"; }
bin=$(bash "$here/../build-at.sh" "$1")
dest=${2:-$here/$(label "$1")}
shift $(( $# >= 2 ? 2 : 1 ))
scenes=${*:-cornell cornell_area cornell_buddha sponza}
a=experiments/area-accuracy
out=$(mktemp -d)
mkdir -p "$dest"
: >"$dest/errors.txt"
for s in $scenes; do
  case $s in
    cornell) scene=scenes/cornell_box.toml; ref=$a/cornell-area-converged-reference.csv ;;
    cornell_area) scene=scenes/cornell_area.toml; ref=experiments/emitters/cpu/accuracy/cornell_area-area-converged-reference.csv ;;
    cornell_buddha) scene=scenes/shared/cornell_buddha.toml; ref=$a/cornell_buddha-area-converged-reference.csv ;;
    sponza) scene=scenes/shared/sponza.toml; ref=$a/sponza-area-converged-reference.csv ;;
    *) echo "unknown scene $s" >&2; exit 2 ;;
  esac
  tail -n +3 "$ref" | cut -d, -f1-6 | tr ',' ' ' >"$out/$s.txt"
  for read in probe basis; do
    set=(); [ $read = basis ] && set=(--set final_gather=0)
    t=$SECONDS
    "$bin" probe "$scene" --points "$out/$s.txt" --out "$out/$s-$read.csv" --backend cpu "${set[@]}" -q 2>/dev/null
    {
      echo "$s, $read ($((SECONDS - t)) s load to CSV):"
      python3 $a/errors_at_points.py "$ref" "$out/$s-$read.csv" | sed 's/^/  /'
    } | tee -a "$dest/errors.txt"
  done
done
