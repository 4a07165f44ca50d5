#!/usr/bin/env bash
# A relaxed oracle for the bounces after the first, against run time and accuracy.
# VARIANT is the commit with the relaxed oracle, b69bf5a (branch variant/relaxed-oracle:
# d6982d0 plus the change that was relaxed-oracle.patch): its oracle's relative allowance
# is eps_rel (|g| + F |indirect so far|), F from MESHRAD_LATER_F (0: today's oracle, the
# bounces after the first then refine less the more light a node already has). REF is the
# commit it was made against, d6982d0, timed beside it. Both may also be binaries; a
# commit is built by experiments/build-at.sh.
# Per configuration F:EPS_REL: the basis read (final_gather = 0; the later bounces' field
# is what the basis carries) at the 256 area-uniform points of the cached converged
# references (the spot-lit box, the area-lit box, Cornell + Buddha), errors by
# experiments/area-accuracy/errors_at_points.py; then the embedded box's default CPU solve,
# all configurations and REF interleaved, ROUNDS rounds (default 5).
# Usage: bash experiments/oracle-later-bounces/run.sh VARIANT REF F:EPS...   (from the
#   repository root), e.g. b69bf5a d6982d0 0:0.1 0.25:0.1 1:0.1; writes accuracy.txt and
#   times.csv beside this file.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
[ $# -ge 3 ] || { sed -n '2,20p' "$0" >&2; exit 2; }
bin=$(bash "$here/../build-at.sh" "$1") ref_bin=$(bash "$here/../build-at.sh" "$2"); shift 2
rounds=${ROUNDS:-5}
a=experiments/area-accuracy
tmp=$(mktemp -d)
: >"$here/accuracy.txt"
for cfg in "$@"; do
  f=${cfg%:*} e=${cfg#*:}
  line="F=$f eps_rel=$e"
  for s in cornell cornell_area cornell_buddha; do
    case $s in
      cornell) scene=scenes/cornell_box.toml; ref=$a/cornell-area-converged-reference.csv ;;
      cornell_area) scene=scenes/cornell_area.toml; ref=experiments/emitters/cpu/accuracy/cornell_area-area-converged-reference.csv ;;
      *) scene=scenes/shared/cornell_buddha.toml; ref=$a/cornell_buddha-area-converged-reference.csv ;;
    esac
    tail -n +3 "$ref" | cut -d, -f1-6 | tr ',' ' ' >"$tmp/$s.txt"
    MESHRAD_LATER_F=$f "$bin" probe "$scene" --points "$tmp/$s.txt" --out "$tmp/$s.csv" --backend cpu -q \
      --set final_gather=0 --set eps_rel="$e" 2>/dev/null
    line="$line | $s $(python3 $a/errors_at_points.py "$ref" "$tmp/$s.csv")"
  done
  echo "$line" >>"$here/accuracy.txt"
done
echo "config,round,total_s,bounce1_s,later_s,later_over_first,integrals,integrals_traced" >"$here/times.csv"
for r in $(seq "$rounds"); do
  for cfg in ref "$@"; do
    if [ "$cfg" = ref ]; then
      "$ref_bin" solve --backend cpu --out "$tmp/o" -q 2>/dev/null
    else
      MESHRAD_LATER_F=${cfg%:*} "$bin" solve --backend cpu --out "$tmp/o" -q --set eps_rel="${cfg#*:}" 2>/dev/null
    fi
    python3 - "$tmp/o/stats.json" "$cfg" "$r" >>"$here/times.csv" <<'PY'
import json, sys
d = json.load(open(sys.argv[1])); b = d["solve"]["bounces"]
first = b[0]["seconds"]; later = sum(x["seconds"] for x in b[1:])
print(f'{sys.argv[2]},{sys.argv[3]},{d["seconds"]["total"]:.4f},{first:.4f},{later:.4f},{later / first:.4f},'
      f'{d["solve"]["integrals"]},{d["solve"]["links"]["integrals_traced"]}')
PY
  done
done
cat "$here/accuracy.txt"
python3 - "$here/times.csv" <<'PY'
import csv, statistics, sys
rows = list(csv.DictReader(open(sys.argv[1])))
for cfg in dict.fromkeys(r["config"] for r in rows):
    rs = [r for r in rows if r["config"] == cfg]
    med = lambda k: statistics.median(float(r[k]) for r in rs)
    print(f'{cfg}: total {med("total_s"):.3f} s, bounce 1 {med("bounce1_s"):.3f} s, later {med("later_s"):.3f} s, '
          f'later/first {med("later_over_first"):.3f}, integrals {rs[0]["integrals"]}, traced {rs[0]["integrals_traced"]}')
PY
