#!/usr/bin/env bash
# Issue #32's cost bound: Sponza's probe run (load to CSV) at the defaults, binaries
# interleaved, ROUNDS rounds, each run alone on the machine; prints one line per run.
# Usage (from the repository root):
#   bash experiments/interiors/cost.sh OUT_DIR SEED ROUNDS BIN|COMMIT... [-- --set KEY=VALUE ...]
# SCENE and OBJ as in run.sh; OUT_DIR/points-SEED.txt is drawn if missing.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
[ $# -ge 4 ] || { sed -n '2,7p' "$0" >&2; exit 2; }
out=$1 seed=$2 rounds=$3; shift 3
bins=(); while [ $# -gt 0 ] && [ "$1" != -- ]; do bins+=("$(bash "$here/../build-at.sh" "$1")"); shift; done
[ "${1:-}" = -- ] && shift
scene=${SCENE:-$here/sponza-defaults.toml}
obj=${OBJ:-${MESHRAD_SCENES:-../shared/scenes}/sponza_dabrovic/sponza.obj}
mkdir -p "$out"
pts=$out/points-$seed.txt
[ -f "$pts" ] || python3 "$here/points.py" "$obj" 256 "$seed" >"$pts"
for r in $(seq "$rounds"); do
  for b in "${bins[@]}"; do
    t0=$(date +%s.%N)
    "$b" probe "$scene" --points "$pts" --out "$out/cost-$(basename "$b").csv" --backend cpu "$@" -q 2>/dev/null
    t1=$(date +%s.%N)
    echo "round $r $(basename "$b") $(python3 -c "print(f'{$t1 - $t0:.1f}')") s load to CSV"
  done
done
