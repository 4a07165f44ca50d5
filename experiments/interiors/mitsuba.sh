#!/usr/bin/env bash
# Issue #32: Mitsuba 3's irradiance at the interiors' area-uniform points, an independent
# check of `meshrad reference --points` (131072 paths a point): the scene exported as
# meshrad loads it (`meshrad bench mitsuba`), then the export's points.py (cosine rays
# traced by Mitsuba's `path` integrator, llvm_ad_rgb), then errors_at_points.py with
# Mitsuba as the reference, against meshrad's reference and against a probe CSV.
# Usage (from the repository root; needs `pip install mitsuba` and Debian's libllvm19):
#   bash experiments/interiors/mitsuba.sh BIN SCENE.toml POINTS_DIR NAME OUT_DIR [PROBE_CSV_PATTERN]
# POINTS_DIR holds points-SEED.txt and reference-SEED.csv for seeds 7 and 11; the
# optional pattern names probe CSVs with SEED in place of the seed. The export goes to
# ${TMPDIR:-/tmp}/meshrad-mitsuba-NAME (tens of MB); OUT_DIR gets NAME-SEED.csv.
set -euo pipefail
[ $# -ge 5 ] || { sed -n '2,10p' "$0" >&2; exit 2; }
bin=$1 scene=$2 pts=$3 name=$4 out=$5 probes=${6:-}
here=$(cd "$(dirname "$0")" && pwd)
ex=${TMPDIR:-/tmp}/meshrad-mitsuba-$name
mkdir -p "$out"
"$bin" bench mitsuba "$scene" --out "$ex"
for s in 7 11; do
  csv=$out/$name-$s.csv
  [ -f "$csv" ] || python3 "$ex/points.py" "$ex" "$pts/points-$s.txt" 131072 "$csv" "$s"
  echo "$name seed $s: meshrad's reference against Mitsuba's"
  python3 "$here/../area-accuracy/errors_at_points.py" "$csv" <(tail -n +2 "$pts/reference-$s.csv") | sed 's/^/  /'
  if [ -n "$probes" ]; then
    echo "$name seed $s: ${probes//SEED/$s} against Mitsuba's"
    python3 "$here/../area-accuracy/errors_at_points.py" "$csv" "${probes//SEED/$s}" | sed 's/^/  /'
  fi
done
