#!/usr/bin/env bash
# End-to-end wall time of several meshrad binaries (or settings) on one scene, alternating,
# RUNS runs each (default 3), then the medians: `solve` (writes the images) and `probe` at
# the points P (px py pz nx ny nz per line). Old and new binary in one run, on the same
# cores, so the ratios are comparable even on a shared machine.
# Usage: times.sh SCENE.toml POINTS LABEL=COMMIT|BINARY[:--set KEY=VALUE ...] ...
#   e.g. times.sh scenes/cornell_box.toml experiments/links/cornell-points.txt old=8e58d75 new=target/release/meshrad
#   (a commit is built by experiments/build-at.sh)
set -u
here=$(cd "$(dirname "$0")" && pwd)
scene=$1 pts=$2; shift 2
# LABEL=COMMIT specs made LABEL=BINARY before any run.
specs=()
for spec in "$@"; do
  label=${spec%%=*}; rest=${spec#*=}; what=${rest%%:*}; args=""
  [ "$rest" != "$what" ] && args=":${rest#*:}"
  bin=$(bash "$here/../build-at.sh" "$what") || exit 2
  specs+=("$label=$bin$args")
done
set -- "${specs[@]}"
runs=${RUNS:-3} out=$(mktemp -d)
for i in $(seq "$runs"); do
  for spec in "$@"; do
    label=${spec%%=*}; rest=${spec#*=}; bin=${rest%%:*}; args=""
    [ "$rest" != "$bin" ] && args=${rest#*:}
    s=$(date +%s.%N); $bin solve "$scene" --backend cpu --out "$out/$label" -q $args >/dev/null 2>&1; e=$(date +%s.%N)
    $bin probe "$scene" --backend cpu --points "$pts" --out "$out/$label.csv" $args >/dev/null 2>&1
    e2=$(date +%s.%N)
    echo "$label run $i: solve $(echo "$e - $s" | bc) s, probe $(echo "$e2 - $e" | bc) s"
  done
done | tee "$out/log"
echo "medians:"
for spec in "$@"; do
  label=${spec%%=*}
  python3 - "$out/log" "$label" <<'P'
import sys, statistics as st
rows = [l.split() for l in open(sys.argv[1]) if l.startswith(sys.argv[2] + " run ")]
s = st.median(float(r[4]) for r in rows); p = st.median(float(r[7]) for r in rows)
print(f"{sys.argv[2]}: solve {s:.2f} s, probe {p:.2f} s ({len(rows)} runs)")
P
done
echo "outputs in $out"
