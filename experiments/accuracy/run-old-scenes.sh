#!/usr/bin/env bash
# Accuracy of two commits (OLD, e.g. 2ebc7c1, and NEW) in one run, at the 256 area-uniform points
# of the cached converged references (experiments/area-accuracy), CPU backend, defaults:
# `meshrad probe SCENE --points P`, errors by experiments/area-accuracy/errors_at_points.py.
# Old binaries read the scene files of their commit (OLD_SCENES: cornell_box.toml and
# cornell_buddha.toml from 2ebc7c1); the new one reads today's (emission = false keeps
# the light quad a plain surface, as the old code did).
# OLD and NEW: commits (built by experiments/build-at.sh) or binaries. OLD_SCENES: the
# old commit's scenes/ folder; by default, when OLD is a commit, its scenes/ as committed.
# Usage: bash experiments/accuracy/run-old-scenes.sh OLD NEW [OLD_SCENES [OUT_DIR]]
#   (from the repository root); writes OUT_DIR/errors.txt, OUT_DIR by default
#   experiments/accuracy/OLD-vs-NEW (short commit ids, or the binaries' file names).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
[ $# -ge 2 ] || { sed -n '2,13p' "$0" >&2; exit 2; }
label() { git rev-parse -q --verify --short "$1^{commit}" 2>/dev/null || basename "$1"; }
dest=${4:-$here/$(label "$1")-vs-$(label "$2")}
old=$(bash "$here/../build-at.sh" "$1") new=$(bash "$here/../build-at.sh" "$2")
old_scenes=${3:-}
if [ -z "$old_scenes" ]; then
  old_scenes=$(mktemp -d)
  git archive "$1" scenes | tar -x -C "$old_scenes"
  old_scenes=$old_scenes/scenes
fi
mkdir -p "$dest"
a=experiments/area-accuracy
out=$(mktemp -d)
: >"$dest/errors.txt"
for s in cornell cornell_buddha; do
  tail -n +3 "$a/$s-area-converged-reference.csv" | cut -d, -f1-6 | tr ',' ' ' >"$out/$s.txt"
  case $s in
    cornell) newscene=scenes/cornell_box.toml; oldscene=$old_scenes/cornell_box.toml ;;
    *) newscene=scenes/shared/cornell_buddha.toml; oldscene=$old_scenes/cornell_buddha.toml ;;
  esac
  "$old" probe "$oldscene" --points "$out/$s.txt" --out "$out/$s-old.csv" --backend cpu -q 2>/dev/null
  "$new" probe "$newscene" --points "$out/$s.txt" --out "$out/$s-new.csv" --backend cpu -q 2>/dev/null
  for b in old new; do
    echo "$s $b: $(python3 $a/errors_at_points.py $a/$s-area-converged-reference.csv "$out/$s-$b.csv")" >>"$dest/errors.txt"
  done
done
cat "$dest/errors.txt"
