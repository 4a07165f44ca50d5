#!/usr/bin/env bash
# Issue #33: where the Cornell box's image error away from edges comes from. The default
# image (16 spp) of the embedded box against two 2048-path reference images, for five
# solver seeds and for 2× and 4× the rays per integral: if the error away from edges is
# the integrals' Monte Carlo noise, it moves with the seed and falls with the rays.
# Usage (from the repository root):
#   bash experiments/images/seeds/run.sh REF_DIR BIN OUT_DIR [LABEL=SETTINGS...]
# REF_DIR holds cornell-image-reference-256x256-2048-seed1/ and -seed2/ (as `meshrad bench
# accuracy --images-only --image-reference 2048 --out REF_DIR` leaves them).
# LABEL=KEY=VALUE[,KEY=VALUE...]: solver settings. Each line:
# the wall time of `meshrad solve` (load to written images, CPU backend) and the total and
# indirect images' errors (experiments/images/image_error.py).
set -euo pipefail
[ $# -ge 3 ] || { sed -n '2,12p' "$0" >&2; exit 2; }
refs=$1 bin=$2 out=$3; shift 3
here=$(cd "$(dirname "$0")" && pwd)
r=$refs/cornell-image-reference-256x256-2048-seed
configs=("$@")
[ ${#configs[@]} -gt 0 ] || configs=(seed0=seed=0 seed1=seed=1 seed2=seed=2 seed3=seed=3 seed4=seed=4 rays1024=rays=1024 rays2048=rays=2048)
mkdir -p "$out"
for c in "${configs[@]}"; do
  label=${c%%=*} set=${c#*=}
  d=$out/$label
  rm -rf "$d"
  t0=$(date +%s.%N)
  sets=(); for kv in ${set//,/ }; do sets+=(--set "$kv"); done
  "$bin" solve --out "$d" -q --backend cpu "${sets[@]}"
  t1=$(date +%s.%N)
  tot=$(python3 "$here/../image_error.py" "${r}1/total.exr" "${r}2/total.exr" "$d/total.exr" | tail -1 | sed 's/^[^:]*: //')
  ind=$(python3 "$here/../image_error.py" "${r}1/indirect.exr" "${r}2/indirect.exr" "$d/indirect.exr" | tail -1 | sed 's/^[^:]*: //')
  printf '%-10s %-12s %6.2f s  total: %s | indirect: %s\n' "$label" "$set" "$(echo "$t1 - $t0" | bc)" "$tot" "$ind"
  rm -rf "$d"
done
