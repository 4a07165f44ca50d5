#!/usr/bin/env bash
# Issue #13's before/after: LABEL=COMMIT or LABEL=BINARY arguments (a commit is built by
# experiments/build-at.sh), run interleaved, 3 runs each, on the embedded Cornell box:
#   cpu      the CPU backend at the defaults (`meshrad solve --backend cpu`);
#   gpu      lavapipe at the defaults;
#   table2   lavapipe at the paper's Table 1 settings, approx (bench table2's GPU approx
#            column's parameters, run cold by `meshrad solve`).
# Writes runs.csv beside this script from each run's stats.json.
# Usage: bash experiments/trace-once/run.sh b0=8e58d75 b1=COMMIT new=target/release/meshrad [modes...]
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
bins=()
modes=()
for a in "$@"; do
  case "$a" in
    *=*) bins+=("${a%%=*}=$(bash "$here/../build-at.sh" "${a#*=}")") ;;
    *) modes+=("$a") ;;
  esac
done
[ ${#modes[@]} -gt 0 ] || modes=(cpu gpu table2)
table2="--variant approx --set levels=6 --set sender_level=4 --set gather_levels=3 --set rays=512
  --set bounces=6 --set coarsest=226 --set stop_threshold=0 --set final_gather=0
  --set exact_first_bounce=false --set noise_z=2 --set sparse_parents=0"
out=$(mktemp -d)
csv="$here/runs.csv"
[ -f "$csv" ] || echo "mode,binary,run,total,load,hierarchy,solve,output,bounce1,bounces_after,bounces_all,kernels,integrals,rays_gathered,rays_traced,links_mib" >"$csv"
for mode in "${modes[@]}"; do
  for i in 1 2 3; do
    for b in "${bins[@]}"; do
      label=${b%%=*}
      bin=${b#*=}
      case "$mode" in
        cpu) args="--backend cpu" ;;
        gpu) args="--backend gpu" ;;
        table2) args="--backend gpu $table2" ;;
      esac
      # shellcheck disable=SC2086
      "$bin" solve $args --out "$out/$label" -q
      python3 - "$out/$label/stats.json" "$mode" "$label" "$i" >>"$csv" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
s, t = d["solve"], d["seconds"]
b = s["bounces"]
k = sum(x for _, x in s.get("kernel_seconds") or [])
l = s.get("links") or {}
r = lambda x: round(x, 3)
print(",".join(str(x) for x in [sys.argv[2], sys.argv[3], sys.argv[4], r(t["total"]), r(t["load"]),
      r(t["hierarchy"]), r(t["solve"]), r(t["output"]), r(b[0]["seconds"]),
      r(sum(x["seconds"] for x in b[1:])), r(s["seconds_bounces"]), r(k), s["integrals"],
      s.get("rays_gathered", 0), s.get("rays_traced", 0), r(l.get("bytes", 0) / 2**20)]))
PY
    done
  done
done
cat "$csv"
