#!/usr/bin/env bash
# Did a refactor change any output? Runs OLD_BIN and NEW_BIN on the same cases and
# compares every EXR, PNG, PLY and probe CSV byte for byte with `cmp` (not stats.json: it
# holds timings). Prints one line per file, `same` or `DIFFERENT`, and exits non-zero on
# any difference (or a missing file, or a case that failed).
# Cases (all with the defaults of the scene file, seed included):
#   box-{cpu,gpu}        the embedded Cornell box: `solve --export-nodes` and `probe`
#                        (scenes/cornell_box.toml) at cornell-points.txt (beside this file)
#   area-{cpu,gpu}       scenes/cornell_area.toml likewise
#   animate-{cpu,gpu}    `animate scenes/cornell_parts.toml --frames scenes/cornell_frames.toml
#                        --points cornell-points.txt` (every frame's images and probe.csv)
#   sponza-cpu           scenes/shared/sponza.toml, `solve --bounces 1 --rays 16
#                        --export-nodes`: the whole hierarchy, cheap transport (meshes from
#                        $MESHRAD_SCENES, default ../shared/scenes beside the repository)
# The GPU cases run on whatever `--backend gpu` takes (lavapipe on a machine without a
# GPU), with MESHRAD_VALIDATION=1. CASES="box-cpu area-cpu" runs a subset.
# Time on the shared 2-core machine (2da1f67 against itself, 95 files): 24 min, of which
# the three lavapipe cases 20 min; the four CPU cases about 4 min.
# Usage: bash experiments/same-outputs/run.sh OLD_BIN NEW_BIN [OUT_DIR]
#   (OLD_BIN/NEW_BIN: binaries, or commits built by experiments/build-at.sh)
set -uo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
[ $# -ge 2 ] || { sed -n '2,18p' "$0" >&2; exit 2; }
old=$(bash "$root/experiments/build-at.sh" "$1") || exit 2
new=$(bash "$root/experiments/build-at.sh" "$2") || exit 2
out=${3:-$(mktemp -d)}
mkdir -p "$out"
out=$(cd "$out" && pwd)
export MESHRAD_SCENES=${MESHRAD_SCENES:-$(cd "$root/.." && pwd)/shared/scenes}
pts=$here/cornell-points.txt
cases=${CASES:-box-cpu box-gpu area-cpu area-gpu animate-cpu animate-gpu sponza-cpu}
cd "$root"
failed=0

# run_case CASE BIN DIR: writes CASE's outputs under DIR.
run_case() {
  local c=$1 bin=$2 d=$3 be=${1##*-}
  local -a env=()
  [ "$be" = gpu ] && env=(MESHRAD_VALIDATION=1)
  mkdir -p "$d"
  case ${c%-*} in
    box)
      env "${env[@]}" nice -n 10 "$bin" solve --backend "$be" --out "$d/solve" --export-nodes "$d/nodes.ply" -q &&
        env "${env[@]}" nice -n 10 "$bin" probe scenes/cornell_box.toml --backend "$be" --points "$pts" --out "$d/probe.csv" -q ;;
    area)
      env "${env[@]}" nice -n 10 "$bin" solve scenes/cornell_area.toml --backend "$be" --out "$d/solve" --export-nodes "$d/nodes.ply" -q &&
        env "${env[@]}" nice -n 10 "$bin" probe scenes/cornell_area.toml --backend "$be" --points "$pts" --out "$d/probe.csv" -q ;;
    animate)
      env "${env[@]}" nice -n 10 "$bin" animate scenes/cornell_parts.toml --frames scenes/cornell_frames.toml \
        --points "$pts" --backend "$be" --out "$d/anim" -q >/dev/null ;;
    sponza)
      nice -n 10 "$bin" solve scenes/shared/sponza.toml --backend cpu --bounces 1 --rays 16 \
        --out "$d/solve" --export-nodes "$d/nodes.ply" -q ;;
    *) echo "unknown case $c" >&2; return 2 ;;
  esac
}

start=$SECONDS
for c in $cases; do
  for side in old new; do
    bin=$old; [ $side = new ] && bin=$new
    rm -rf "${out:?}/$side/$c"
    t=$SECONDS
    if ! run_case "$c" "$bin" "$out/$side/$c" 2>"$out/$side-$c.err"; then
      echo "$c: $side binary FAILED ($(tail -n 1 "$out/$side-$c.err"))"; failed=1
    fi
    echo "$c: $side ran in $((SECONDS - t)) s" >&2
  done
  # Every compared file either side wrote, in order.
  files=$( (cd "$out/old/$c" 2>/dev/null && find . -type f; cd "$out/new/$c" 2>/dev/null && find . -type f) |
    grep -E '\.(exr|png|ply|csv)$' | sort -u)
  [ -n "$files" ] || { echo "$c: no outputs"; failed=1; }
  for f in $files; do
    f=${f#./}
    if [ ! -f "$out/old/$c/$f" ] || [ ! -f "$out/new/$c/$f" ]; then
      echo "DIFFERENT $c/$f (only one binary wrote it)"; failed=1
    elif cmp -s "$out/old/$c/$f" "$out/new/$c/$f"; then
      echo "same      $c/$f"
    else
      echo "DIFFERENT $c/$f"; failed=1
    fi
  done
done
echo "$((SECONDS - start)) s; outputs in $out" >&2
[ $failed = 0 ] && echo "all same" || echo "SOME OUTPUTS DIFFER (or a run failed)"
exit $failed
