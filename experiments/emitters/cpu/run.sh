#!/usr/bin/env bash
# Emitting surfaces (issue #11): what the luminaire costs against the spot on the same
# box (embedded scenes, CPU backend, defaults, 3 runs each interleaved), and the area-lit
# box against the converged reference at 256 area-uniform points.
# Usage: bash experiments/emitters/cpu/run.sh [COMMIT|BINARY]   (default target/release/meshrad); writes beside this file.
#   (from the repository root; a commit is built by experiments/build-at.sh)
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
bin=$(bash "$here/../../build-at.sh" "${1:-target/release/meshrad}")
out=$(mktemp -d)
csv="$here/costs.csv"
echo "scene,run,total,hierarchy,direct,bounce1,bounces_all,integrals,rays_gathered,emitter_shadow_rays,direct_mean_rel_se,direct_max_rel_se" >"$csv"
for i in 1 2 3; do
  for s in cornell_box cornell_area; do
    "$bin" solve "scenes/$s.toml" --backend cpu --out "$out/$s" -q
    python3 - "$out/$s/stats.json" "$s" "$i" >>"$csv" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
s, t = d["solve"], d["seconds"]
e = s.get("direct_error") or {}
r = lambda x: round(x, 3)
print(",".join(str(x) for x in [sys.argv[2], sys.argv[3], r(t["total"]), r(t["hierarchy"]), r(s["seconds_direct"]),
      r(s["bounces"][0]["seconds"]), r(s["seconds_bounces"]), s["integrals"], s["rays_gathered"],
      e.get("shadow_rays", 0), round(e.get("mean_rel_std_err", 0), 5), round(e.get("max_rel_std_err", 0), 5)]))
PY
  done
done
cat "$csv"
"$bin" bench accuracy scenes/cornell_area.toml --backend cpu --defaults-only --probes 256 --pathtrace 0 \
  --reference-samples 16384 --out "$here/accuracy" -q
