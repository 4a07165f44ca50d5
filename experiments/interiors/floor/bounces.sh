#!/usr/bin/env bash
# Issue #32: bounce by bounce at Sponza's held-out points (seed 11), up to the fourth
# bounce. The reference cut at k bounces (`--max-bounces k`, 65536 paths, k = 1..4) and
# the probes with the solve cut at k-1 bounces (`--bounces k-1`), so that the final
# gather's exact hop plus the solve's k-1 bounces meets the reference's k; then
# bounces.py prints each bounce's increment (energy estimate/reference) in the
# indirect-only stratum and what the bounces after the fourth deliver.
# Usage (repository root): bash experiments/interiors/floor/bounces.sh BIN OUT_DIR
# (references already in OUT_DIR, e.g. copied from f7d3a37/, are kept)
set -euo pipefail
bin=$1 out=$2 d=experiments/interiors
pts=$d/results/ray-trade/points-11.txt
mkdir -p "$out"
for k in 0 1 2 3; do
  "$bin" probe $d/sponza-defaults.toml --points $pts --out "$out/probe-b$k.csv" --backend cpu --bounces $k -q 2>/dev/null
done
for k in 1 2 3 4; do
  [ -f "$out/ref-b$k.csv" ] && continue # the references do not depend on the binary: kept
  "$bin" reference $d/sponza-defaults.toml --points $pts --samples 65536 --max-bounces $k --out "$out/ref-b$k.csv" -q
done
"$bin" probe $d/sponza-defaults.toml --points $pts --out "$out/probe.csv" --backend cpu -q 2>/dev/null
python3 "$(dirname "$0")/bounces.py" "$out" $d/results/ray-trade/reference-11.csv 3 "$out/probe.csv"
