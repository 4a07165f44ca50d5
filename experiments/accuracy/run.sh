#!/usr/bin/env bash
# Accuracy of the old (4db40bf) and new binaries in one run, at the 256 area-uniform points
# of the cached converged references, CPU backend, defaults: the spot-lit box and Buddha
# (experiments/area-accuracy) and the area-lit box (experiments/emitters/cpu/accuracy),
# `meshrad probe SCENE --points P`, errors by experiments/area-accuracy/errors_at_points.py
# (rel-RMS, median and mean of estimate/reference). Both binaries read today's scene files.
# Usage: bash run.sh OLD_BIN NEW_BIN; writes errors.txt beside this file.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
old=$1 new=$2
a=experiments/area-accuracy
out=$(mktemp -d)
: >"$here/errors.txt"
for s in cornell cornell_area cornell_buddha; do
  case $s in
    cornell) scene=scenes/cornell_box.toml; ref=$a/cornell-area-converged-reference.csv ;;
    cornell_area) scene=scenes/cornell_area.toml; ref=experiments/emitters/cpu/accuracy/cornell_area-area-converged-reference.csv ;;
    *) scene=scenes/shared/cornell_buddha.toml; ref=$a/cornell_buddha-area-converged-reference.csv ;;
  esac
  tail -n +3 "$ref" | cut -d, -f1-6 | tr ',' ' ' >"$out/$s.txt"
  for b in old new; do
    bin=$old; [ $b = new ] && bin=$new
    "$bin" probe "$scene" --points "$out/$s.txt" --out "$out/$s-$b.csv" --backend cpu -q 2>/dev/null
    echo "$s $b: $(python3 $a/errors_at_points.py "$ref" "$out/$s-$b.csv")" >>"$here/errors.txt"
  done
done
cat "$here/errors.txt"
