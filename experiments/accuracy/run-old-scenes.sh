#!/usr/bin/env bash
# Accuracy of the old (2ebc7c1) and new binaries in one run, at the 256 area-uniform points
# of the cached converged references (experiments/area-accuracy), CPU backend, defaults:
# `meshrad probe SCENE --points P`, errors by experiments/area-accuracy/errors_at_points.py.
# Old binaries read the scene files of their commit (OLD_SCENES: cornell_box.toml and
# cornell_buddha.toml from 2ebc7c1); the new one reads today's (emission = false keeps
# the light quad a plain surface, as the old code did).
# Usage: bash run.sh OLD_BIN NEW_BIN OLD_SCENES; writes errors.txt beside this file.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
old=$1 new=$2 old_scenes=$3
a=experiments/area-accuracy
out=$(mktemp -d)
: >"$here/errors.txt"
for s in cornell cornell_buddha; do
  tail -n +3 "$a/$s-area-converged-reference.csv" | cut -d, -f1-6 | tr ',' ' ' >"$out/$s.txt"
  case $s in
    cornell) newscene=scenes/cornell_box.toml; oldscene=$old_scenes/cornell_box.toml ;;
    *) newscene=scenes/shared/cornell_buddha.toml; oldscene=$old_scenes/cornell_buddha.toml ;;
  esac
  "$old" probe "$oldscene" --points "$out/$s.txt" --out "$out/$s-old.csv" --backend cpu -q 2>/dev/null
  "$new" probe "$newscene" --points "$out/$s.txt" --out "$out/$s-new.csv" --backend cpu -q 2>/dev/null
  for b in old new; do
    echo "$s $b: $(python3 $a/errors_at_points.py $a/$s-area-converged-reference.csv "$out/$s-$b.csv")" >>"$here/errors.txt"
  done
done
cat "$here/errors.txt"
