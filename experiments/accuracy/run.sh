#!/usr/bin/env bash
# Accuracy of two commits (OLD, NEW) in one run, at the 256 area-uniform points
# of the cached converged references, CPU backend, defaults: the spot-lit box and Buddha
# (experiments/area-accuracy) and the area-lit box (experiments/emitters/cpu/accuracy),
# `meshrad probe SCENE --points P`, errors by experiments/area-accuracy/errors_at_points.py
# (rel-RMS, median and mean of estimate/reference). Both binaries read today's scene files.
# OLD and NEW: commits (built by experiments/build-at.sh) or binaries.
# Usage: bash experiments/accuracy/run.sh OLD NEW [OUT_DIR]   (from the repository root)
#   writes OUT_DIR/errors.txt, OUT_DIR by default experiments/accuracy/OLD-vs-NEW (short
#   commit ids, or the binaries' file names).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
[ $# -ge 2 ] || { sed -n '2,12p' "$0" >&2; exit 2; }
label() { git rev-parse -q --verify --short "$1^{commit}" 2>/dev/null || basename "$1"; }
dest=${3:-$here/$(label "$1")-vs-$(label "$2")}
old=$(bash "$here/../build-at.sh" "$1") new=$(bash "$here/../build-at.sh" "$2")
mkdir -p "$dest"
a=experiments/area-accuracy
out=$(mktemp -d)
: >"$dest/errors.txt"
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
    echo "$s $b: $(python3 $a/errors_at_points.py "$ref" "$out/$s-$b.csv")" >>"$dest/errors.txt"
  done
done
cat "$dest/errors.txt"
