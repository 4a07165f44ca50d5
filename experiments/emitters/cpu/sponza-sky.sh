#!/usr/bin/env bash
# What the sky adds to Sponza (issue #11): sponza.toml (sun) and sponza_sky.toml (sun + a
# constant sky), CPU backend, defaults, one run each, in one run of this script.
# Usage: bash experiments/emitters/cpu/sponza-sky.sh [COMMIT|BINARY]; writes sponza-sky.csv beside it.
#   (from the repository root; a commit is built by experiments/build-at.sh)
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
bin=$(bash "$here/../../build-at.sh" "${1:-target/release/meshrad}")
out=$(mktemp -d)
csv="$here/sponza-sky.csv"
echo "scene,total,hierarchy,direct,bounce1,bounces_all,integrals,rays_gathered,sky_and_emitter_rays_at_nodes,direct_mean_rel_se,output" >"$csv"
for s in sponza sponza_sky; do
  "$bin" solve "scenes/shared/$s.toml" --backend cpu --out "$out/$s" -q
  python3 - "$out/$s/stats.json" "$s" >>"$csv" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
s, t = d["solve"], d["seconds"]
e = s.get("direct_error") or {}
r = lambda x: round(x, 3)
print(",".join(str(x) for x in [sys.argv[2], r(t["total"]), r(t["hierarchy"]), r(s["seconds_direct"]),
      r(s["bounces"][0]["seconds"]), r(s["seconds_bounces"]), s["integrals"], s["rays_gathered"],
      e.get("shadow_rays", 0), round(e.get("mean_rel_std_err", 0), 5), r(t["output"])]))
PY
done
cat "$csv"
