#!/usr/bin/env bash
# Issue #32: the whole solution at points drawn uniformly by area over every triangle of
# an interior (the side at random), against a converged reference (`meshrad reference`,
# 131072 paths a point, the unbounded series), per stratum (points lit only indirectly,
# lit points; experiments/area-accuracy/errors_at_points.py). For each binary: `probe`
# (final gather) and, with `--set final_gather=0`, the basis read; CPU backend, defaults.
# Usage (from the repository root):
#   bash experiments/interiors/run.sh OUT_DIR SEED BIN|COMMIT... [-- --set KEY=VALUE ...]
# SCENE (default experiments/interiors/sponza-defaults.toml) and OBJ (its mesh, default
# $MESHRAD_SCENES/sponza_dabrovic/sponza.obj) may be set in the environment. The
# reference comes from the first binary and is kept in OUT_DIR for later runs.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
[ $# -ge 3 ] || { sed -n '2,11p' "$0" >&2; exit 2; }
out=$1 seed=$2; shift 2
bins=(); while [ $# -gt 0 ] && [ "$1" != -- ]; do bins+=("$(bash "$here/../build-at.sh" "$1")"); shift; done
[ "${1:-}" = -- ] && shift
scene=${SCENE:-$here/sponza-defaults.toml}
obj=${OBJ:-${MESHRAD_SCENES:-../shared/scenes}/sponza_dabrovic/sponza.obj}
mkdir -p "$out"
pts=$out/points-$seed.txt ref=$out/reference-$seed.csv
[ -f "$pts" ] || python3 "$here/points.py" "$obj" 256 "$seed" >"$pts"
if [ ! -f "$ref" ]; then
  "${bins[0]}" reference "$scene" --points "$pts" --samples 131072 --out "$out/raw.csv" -q
  { echo "# meshrad reference samples=131072 max_bounces=0"; cat "$out/raw.csv"; } >"$ref"
  rm "$out/raw.csv"
fi
for b in "${bins[@]}"; do
  for read in probe basis; do
    set=(); [ $read = basis ] && set=(--set final_gather=0)
    csv=$out/$(basename "$b")-$seed-$read.csv
    t=$SECONDS
    "$b" probe "$scene" --points "$pts" --out "$csv" --backend cpu "${set[@]}" "$@" -q 2>/dev/null
    echo "$(basename "$b") seed $seed, $read ($((SECONDS - t)) s load to CSV) $*:"
    python3 "$here/../area-accuracy/errors_at_points.py" "$ref" "$csv" | sed 's/^/  /'
  done
done
