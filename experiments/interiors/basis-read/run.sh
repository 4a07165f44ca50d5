#!/usr/bin/env bash
# Issue #32: the probes' basis read (`final_gather = 0`) with its two tests of the point
# (`basis_crevice`, `basis_visibility`; ALGORITHM.md §6) switched on and off one at a
# time, and the points read as the image reads them (`--read image`), at the staircase's
# area-uniform points against their 131072-path references (experiments/interiors/
# staircase/), indirect-only and lit strata (experiments/area-accuracy/errors_at_points.py).
# CPU backend, defaults otherwise; one solve per run.
# Usage (from the repository root):
#   bash experiments/interiors/basis-read/run.sh OUT_DIR BIN|COMMIT [SEED...]
# SCENE: the converted staircase (default $MESHRAD_SCENES/public/staircase/staircase.toml,
# from `bash scenes/fetch.sh staircase`); POINTS: the directory of points-SEED.txt and
# reference-SEED.csv (default experiments/interiors/staircase). Seeds default to 7 11.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
[ $# -ge 2 ] || { sed -n '2,13p' "$0" >&2; exit 2; }
out=$1 bin=$(bash "$here/../../build-at.sh" "$2"); shift 2
seeds=("$@"); [ ${#seeds[@]} -gt 0 ] || seeds=(7 11)
scene=${SCENE:-${MESHRAD_SCENES:-../shared/scenes}/public/staircase/staircase.toml}
pts=${POINTS:-$here/../staircase}
mkdir -p "$out"
for s in "${seeds[@]}"; do
  for v in "both|" "crevice only|--set basis_visibility=false" "visibility only|--set basis_crevice=false" \
    "neither|--set basis_crevice=false --set basis_visibility=false" "image|--read image"; do
    IFS='|' read -r name set <<<"$v"
    args=(--set final_gather=0); [ "$name" = image ] && args=()
    csv="$out/$(basename "$bin")-$s-${name// /-}.csv"
    t=$SECONDS
    # shellcheck disable=SC2086
    "$bin" probe "$scene" --points "$pts/points-$s.txt" --out "$csv" --backend cpu "${args[@]}" $set -q 2>/dev/null
    echo "$(basename "$bin") seed $s, $name ($((SECONDS - t)) s load to CSV):"
    python3 "$here/../../area-accuracy/errors_at_points.py" "$pts/reference-$s.csv" "$csv" | sed 's/^/  /'
  done
done
