#!/usr/bin/env bash
# Bounce by bounce at the points of seed 7 (issue #32, step 2): the reference cut at k
# bounces (`--max-bounces k`, 65536 paths) and the probes with the solve cut at k-1
# bounces (`--bounces`), so that the final gather's exact hop plus the solve's k-1 bounces
# meets the reference's k. Compare the increments per point (indirect-only stratum).
# Usage (repository root): bash experiments/interiors/results/bounces.sh BIN OUT_DIR
set -euo pipefail
bin=$1 out=$2 d=experiments/interiors
mkdir -p "$out"
for k in 1 2 3; do
  "$bin" reference $d/sponza-defaults.toml --points $d/results/points-7.txt --samples 65536 --max-bounces $k --out "$out/ref-b$k.csv" -q
done
for k in 0 1 2; do
  "$bin" probe $d/sponza-defaults.toml --points $d/results/points-7.txt --out "$out/probe-b$k.csv" --backend cpu --bounces $k -q 2>/dev/null
done
