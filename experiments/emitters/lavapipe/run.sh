#!/usr/bin/env bash
# Emitting surfaces on the GPU backend (issue #11): what the luminaire costs against the
# spot on the same box (embedded scenes, defaults, 3 runs each interleaved), on whatever
# device `--backend gpu` takes (lavapipe on the 2-core machine).
# Usage: bash experiments/emitters/lavapipe/run.sh [COMMIT|BINARY]   (default target/release/meshrad); writes costs.csv beside this file.
#   (from the repository root; a commit is built by experiments/build-at.sh)
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
bin=$(bash "$here/../../build-at.sh" "${1:-target/release/meshrad}")
out=$(mktemp -d)
csv="$here/costs.csv"
echo "scene,run,total,hierarchy,direct,bounce1,bounces_all,kernel_direct,kernel_reconstruct,integrals,rays_traced,emitter_shadow_rays,direct_mean_rel_se,device" >"$csv"
for i in 1 2 3; do
  for s in cornell_box cornell_area; do
    "$bin" solve "scenes/$s.toml" --backend gpu --out "$out/$s" -q
    python3 - "$out/$s/stats.json" "$s" "$i" >>"$csv" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
s, t = d["solve"], d["seconds"]
e = s.get("direct_error") or {}
k = dict(s["kernel_seconds"])
r = lambda x: round(x, 3)
dev = d["gpu"]["device"].split(" (")[0]
print(",".join(str(x) for x in [sys.argv[2], sys.argv[3], r(t["total"]), r(t["hierarchy"]), r(s["seconds_direct"]),
      r(s["bounces"][0]["seconds"]), r(s["seconds_bounces"]), r(k.get("direct", 0)), r(k.get("reconstruct", 0)),
      s["integrals"], s["rays_traced"], e.get("shadow_rays", 0), round(e.get("mean_rel_std_err", 0), 5), dev]))
PY
  done
done
cat "$csv"
