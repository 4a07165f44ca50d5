#!/usr/bin/env bash
# Interleaved wall times of two binaries on scenes without the new asset features (no
# emission texture, cutout or vertex normal): per round OLD then NEW, each scene.
# Usage: bash experiments/assets/cost.sh OLD NEW OUT_FILE [ROUNDS] [SCENE...]
set -euo pipefail
old=$(bash "$(dirname "$0")/../build-at.sh" "$1"); new=$(bash "$(dirname "$0")/../build-at.sh" "$2"); out=$3
rounds=${4:-3}; shift $(( $# < 4 ? $# : 4 ))
scenes=("$@"); [ ${#scenes[@]} -gt 0 ] || scenes=(scenes/cornell_box.toml scenes/shared/cornell_buddha.toml)
tmp=$(mktemp -d)
for r in $(seq 1 "$rounds"); do
  for b in "$old" "$new"; do
    for s in "${scenes[@]}"; do
      t0=$(date +%s.%N)
      "$b" solve "$s" --backend cpu --out "$tmp/o" -q > /dev/null 2>&1 || echo "FAIL $b $s"
      t1=$(date +%s.%N)
      echo "$r $(basename "$b") $(basename "$s" .toml) $(echo "$t1 - $t0" | bc)" | tee -a "$out"
    done
  done
done
rm -rf "$tmp"
