#!/usr/bin/env bash
# The hierarchy build's before/after (issue #13): LABEL=COMMIT or LABEL=BINARY arguments
# (a commit is built by experiments/build-at.sh), run interleaved, 3 runs each, on the CPU backend:
#   cornell   the embedded Cornell box at the defaults, whole run (load to written images);
#   buddha    scenes/shared/cornell_buddha.toml, hierarchy only (--bounces 0);
#   sponza    scenes/shared/sponza.toml, hierarchy only (--bounces 0).
# Meshes from $MESHRAD_SCENES (default ../shared/scenes). A binary older than the
# `emission` and `name` keys (8e58d75: no emitting surfaces, no names) reads the scene
# without those lines,
# the same scene for it. Writes runs.csv beside this
# script from each run's stats.json, and says which binaries export other nodes than the
# last one.
# Usage: bash experiments/hierarchy-build/run.sh b0=8e58d75 new=target/release/meshrad [scenes...]
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
bins=()
scenes=()
for a in "$@"; do
  case "$a" in
    *=*) bins+=("${a%%=*}=$(bash "$here/../build-at.sh" "${a#*=}")") ;;
    *) scenes+=("$a") ;;
  esac
done
[ ${#scenes[@]} -gt 0 ] || scenes=(cornell buddha sponza)
out=$(mktemp -d)
csv="$here/runs.csv"
[ -f "$csv" ] || echo "scene,binary,run,total,hierarchy,solve,reach,candidates,poisson,kdtree,clips,parents,bounce1,bounces_after" >"$csv"
for scene in "${scenes[@]}"; do
  case "$scene" in
    cornell) args=() ;;
    buddha) args=("$root/scenes/shared/cornell_buddha.toml" --bounces 0) ;;
    sponza) args=("$root/scenes/shared/sponza.toml" --bounces 0) ;;
  esac
  for i in 1 2 3; do
    for b in "${bins[@]}"; do
      label=${b%%=*}
      bin=${b#*=}
      if ! "$bin" solve "${args[@]}" --backend cpu --out "$out/$label" -q --export-nodes "$out/$label.ply" 2>"$out/err"; then
        grep -q -e "unknown field .emission" -e "unknown key" "$out/err" || { cat "$out/err" >&2; exit 1; }
        old=("${args[@]}")
        old[0]="$out/$(basename "${args[0]}")"
        grep -v -e "^emission" -e "^name" "${args[0]}" >"${old[0]}"
        "$bin" solve "${old[@]}" --backend cpu --out "$out/$label" -q --export-nodes "$out/$label.ply"
      fi
      python3 - "$out/$label/stats.json" "$scene" "$label" "$i" >>"$csv" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
t, h, s = d["seconds"], d["hierarchy"], d["solve"]
b = s.get("bounces") or []
r = lambda x: round(x, 3)
print(",".join(str(x) for x in [sys.argv[2], sys.argv[3], sys.argv[4], r(t["total"]), r(t["hierarchy"]), r(t["solve"])]
      + [r(h["seconds_" + k]) for k in ["reach", "candidates", "poisson", "kdtree", "clips", "parents"]]
      + [r(b[0]["seconds"]) if b else "", r(sum(x["seconds"] for x in b[1:])) if b else ""]))
PY
    done
    first=${bins[${#bins[@]}-1]%%=*}
    for b in "${bins[@]}"; do
      label=${b%%=*}
      cmp -s "$out/$first.ply" "$out/$label.ply" || echo "note: $scene: $label exports other nodes than $first" >&2
    done
  done
done
cat "$csv"
