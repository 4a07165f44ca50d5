#!/usr/bin/env bash
# Issue #32's headline table: every scene's indirect-only and lit strata at area-uniform
# points against its converged reference, probes and the basis read, for the filing-time
# binary and later ones in one run (CPU backend, defaults):
#   - the three Cornell scenes at their cached references (experiments/strata/run.sh);
#   - Sponza at the solver's defaults, seeds 7 and 11 (experiments/interiors/results/
#     ray-trade/: points and 131072-path references);
#   - Bitterli's staircase (bash scenes/fetch.sh staircase), seeds 7 and 11
#     (experiments/interiors/staircase/), without the filing-time binary, which refuses
#     its albedo-1 materials (issue #34 made them load).
# Usage (from the repository root):
#   bash experiments/interiors/headline.sh OUT_DIR FILING BIN...   (binaries or commits)
# STAIRCASE: the converted scene file (default $MESHRAD_SCENES/public/staircase/staircase.toml).
# FIRST_ON_STAIRCASE=1: the staircase for the first binary too (one that loads it).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
[ $# -ge 3 ] || { sed -n '2,14p' "$0" >&2; exit 2; }
out=$1; shift
filing=$1 later=("${@:2}")
[ "${FIRST_ON_STAIRCASE:-0}" = 1 ] && later=("$@")
scenes=${MESHRAD_SCENES:-../shared/scenes}
stair=${STAIRCASE:-$scenes/public/staircase/staircase.toml}
mkdir -p "$out/sponza" "$out/staircase"
for b in "$@"; do
  bash "$here/../strata/run.sh" "$b" "$out/strata-$(basename "$b")" cornell cornell_area cornell_buddha >/dev/null
done
for s in 7 11; do
  cp "$here/results/ray-trade/points-$s.txt" "$here/results/ray-trade/reference-$s.csv" "$out/sponza/"
  cp "$here/staircase/points-$s.txt" "$here/staircase/reference-$s.csv" "$out/staircase/"
done
for s in 7 11; do
  bash "$here/run.sh" "$out/sponza" "$s" "$@"
  SCENE=$stair OBJ=${stair%.toml}.obj bash "$here/run.sh" "$out/staircase" "$s" "${later[@]}"
done
for b in "$@"; do echo "== $(basename "$b"): Cornell scenes"; cat "$out/strata-$(basename "$b")/errors.txt"; done
