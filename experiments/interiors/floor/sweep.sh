#!/usr/bin/env bash
# Issue #32: one setting at a time at Sponza's held-out points (seed 11; SEED=7 for the other set), probes, CPU
# backend; each line: the settings, the time load to CSV, the indirect-only stratum's
# median and its errors_at_points.py line.
# Usage (repository root): bash experiments/interiors/floor/sweep.sh BIN OUT_DIR "K=V K=V" ...
set -euo pipefail
bin=$1 out=$2; shift 2
d=experiments/interiors seed=${SEED:-11}
mkdir -p "$out"
for cfg in "$@"; do
  name=$(echo "$cfg" | tr ' =' '_-')
  sets=(); for kv in $cfg; do sets+=(--set "$kv"); done
  t=$SECONDS
  "$bin" probe $d/sponza-defaults.toml --points $d/results/ray-trade/points-$seed.txt --out "$out/$seed-$name.csv" --backend cpu "${sets[@]}" -q 2>/dev/null
  echo "$cfg: $((SECONDS - t)) s $(python3 experiments/area-accuracy/errors_at_points.py $d/results/ray-trade/reference-$seed.csv "$out/$seed-$name.csv" | sed -n 2p)"
done
