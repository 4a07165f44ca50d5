#!/usr/bin/env bash
# Old and new binary on the Cornell box, alternating, 3 runs each: `meshrad solve` (the
# embedded box) and `meshrad probe` at the area-uniform points P (px py pz nx ny nz per
# line, e.g. the first six columns of a bench accuracy reference CSV).
# OLD and NEW: commits (built by experiments/build-at.sh) or binaries.
# Usage: bash experiments/decomposition/old-vs-new.sh OLD NEW POINTS   (from the repository root)
set -u
here=$(cd "$(dirname "$0")" && pwd)
old=$(bash "$here/../build-at.sh" "$1") || exit 2
new=$(bash "$here/../build-at.sh" "$2") || exit 2
pts=$3 out=$(mktemp -d)
for i in 1 2 3; do
  for b in old new; do
    bin=$new; [ $b = old ] && bin=$old
    s=$(date +%s.%N); $bin solve --backend cpu --out "$out/$b" -q >/dev/null 2>&1; e=$(date +%s.%N)
    s2=$(date +%s.%N); $bin probe scenes/cornell_box.toml --backend cpu --points "$pts" --out "$out/$b.csv" >/dev/null 2>&1
    e2=$(date +%s.%N)
    echo "$b run $i: solve $(echo "$e - $s" | bc) s, probe $(echo "$e2 - $s2" | bc) s"
  done
done
