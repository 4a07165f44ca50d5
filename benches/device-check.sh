#!/usr/bin/env bash
# The device check (issue #33): one command that checks the whole GPU path on every
# Vulkan device present, for whenever a machine with a GPU is lent, and that CI runs as
# `--smoke` on lavapipe. It needs only bash, coreutils, awk and a release binary.
#
#   bash benches/device-check.sh BIN [--smoke] [--out DIR]
#
# For every device `BIN devices` lists, each scene is solved on the CPU (once) and on the
# device, and the device's images (direct, indirect, total) are compared with the CPU's
# (`meshrad bench compare`: relative RMS, pass at or below TOL, default 5e-3); an
# `animate` sequence is compared frame by frame the same way; `bench table2` runs on the
# device. Scenes: the Cornell box (the paper's first scene), the area-lit box, the box
# under a sky, and with the public scenes (`$MESHRAD_SCENES`, default ../shared/scenes)
# Cornell + Buddha, Sponza and Sponza under a sky; a scene whose meshes are missing is
# reported as skipped. `--smoke`: three levels, one sample a pixel, the shipped scenes
# only, table2 --smoke. Validation layers are on where the layer is installed.
#
# It writes DIR/report.md (device, driver, date, pass or fail per check, end-to-end and
# solve times, kernel times) and the runs' outputs and logs beside it, and exits 1 if a
# check failed. On a GPU machine (no Rust there): build the release binary here, carry it
# with the Vulkan loader (README, "GPU machines"), and run this script there.
set -uo pipefail

usage() {
  echo "usage: bash benches/device-check.sh BIN [--smoke] [--out DIR]" >&2
  exit 2
}
[ $# -ge 1 ] || usage
BIN="$1"
shift
[ -x "$BIN" ] || { echo "device-check: $BIN is not an executable meshrad binary" >&2; exit 2; }
BIN="$(cd "$(dirname "$BIN")" && pwd)/$(basename "$BIN")"
smoke=0
out=device-check
while [ $# -gt 0 ]; do
  case "$1" in
    --smoke) smoke=1 ;;
    --out) [ $# -ge 2 ] || usage; out="$2"; shift ;;
    *) usage ;;
  esac
  shift
done
TOL="${TOL:-5e-3}"
repo="$(cd "$(dirname "$0")/.." && pwd)"
export MESHRAD_SCENES="${MESHRAD_SCENES:-$repo/../shared/scenes}"
mkdir -p "$out" || exit 2
out="$(cd "$out" && pwd)"
report="$out/report.md"
cd "$repo" || exit 2

if ls /usr/share/vulkan/explicit_layer.d/*validation* >/dev/null 2>&1; then
  export MESHRAD_VALIDATION=1
  validation=on
else
  validation="off (no validation layer installed)"
fi

# Solver settings for every run: at --smoke, small enough for lavapipe in CI.
settings=()
if [ "$smoke" = 1 ]; then
  settings=(--spp 1 --set levels=3 --set sender_level=2)
fi

# name|scene file|public (needs $MESHRAD_SCENES)
scenes=(
  "cornell|scenes/cornell_box.toml|no"
  "cornell_area|scenes/cornell_area.toml|no"
  "cornell_sky|scenes/cornell_sky.toml|no"
)
if [ "$smoke" = 0 ]; then
  scenes+=(
    "cornell_buddha|scenes/shared/cornell_buddha.toml|yes"
    "sponza|scenes/shared/sponza.toml|yes"
    "sponza_sky|scenes/shared/sponza_sky.toml|yes"
  )
fi

now() { date +%s.%N; }
elapsed() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.2f", b - a }'; }
# A number from stats.json: the first `"key": value`.
stat() { grep -o "\"$2\": *[-0-9.e][-0-9.e]*" "$1" 2>/dev/null | head -1 | sed 's/.*: *//'; }
# The kernel times a --stats run printed, as "name t, name t".
kernels() { grep '^kernel ' "$1" 2>/dev/null | sed 's/^kernel \([a-z_]*\): \([0-9.]*\) s/\1 \2/' | paste -sd, - | sed 's/,/, /g'; }

failed=0
{
  echo "# meshrad device check"
  echo
  echo "- date: $(date -u '+%Y-%m-%d %H:%M UTC'); host: $(hostname); mode: $([ "$smoke" = 1 ] && echo smoke || echo full)"
  echo "- binary: \`$BIN\` ($("$BIN" --version 2>&1)); commit: $(git -C "$repo" rev-parse --short HEAD 2>/dev/null || echo unknown)"
  echo "- validation layers: $validation; tolerance (relative RMS, device against CPU): $TOL"
  echo "- settings: ${settings[*]:-as in the scene files}"
  echo "- devices (\`meshrad devices\`):"
  echo
  echo '```'
  "$BIN" devices 2>&1
  echo '```'
  echo
} >"$report"

mapfile -t devices < <("$BIN" devices 2>/dev/null | sed -n 's/^\([0-9][0-9]*\): .*/\1/p')
if [ ${#devices[@]} -eq 0 ]; then
  echo "**FAIL**: no Vulkan device (\`meshrad devices\` listed none)." >>"$report"
  cat "$report"
  exit 1
fi

# Solves `scene` on `backend` (device `dev`) into `dir`; sets wall, code.
solve() {
  local scene="$1" backend="$2" dev="$3" dir="$4"
  local t0 t1 args=(solve "$scene" --backend "$backend" --out "$dir" --stats --exposure 0 "${settings[@]}")
  [ -n "$dev" ] && args+=(--device "$dev")
  t0=$(now)
  "$BIN" "${args[@]}" >"$dir.log" 2>&1
  code=$?
  t1=$(now)
  wall=$(elapsed "$t0" "$t1")
}

# Compares the images of `gpu_dir` with `cpu_dir`: sets `vals` (relative RMS of total,
# direct, indirect; "error" where one could not be read) and `same` (1 when every image
# is within TOL).
compare() {
  local gpu_dir="$1" cpu_dir="$2" v line
  same=1
  vals=()
  for img in total direct indirect; do
    line=$("$BIN" bench compare "$gpu_dir/$img.exr" "$cpu_dir/$img.exr" --tolerance "$TOL" 2>&1) || same=0
    v=$(echo "$line" | sed -n 's/^rel_rms=\([^ ]*\).*/\1/p' | head -1)
    vals+=("${v:-error}")
  done
}

for dev in "${devices[@]}"; do
  name=$("$BIN" devices 2>/dev/null | sed -n "s/^$dev: //p")
  d="$out/device$dev"
  mkdir -p "$d"
  {
    echo "## Device $dev: $name"
    echo
    echo "| check | result | total | direct | indirect | CPU end to end | device end to end | device solve | device image: kernel / pass | validation errors | kernels (s) |"
    echo "|---|---|---|---|---|---|---|---|---|---|---|"
  } >>"$report"
  for entry in "${scenes[@]}"; do
    IFS='|' read -r sname file public <<<"$entry"
    if [ "$public" = yes ]; then
      mesh=$(sed -n 's/^mesh = "\$MESHRAD_SCENES\/\(.*\)"/\1/p' "$file" | head -1)
      if [ ! -f "$MESHRAD_SCENES/$mesh" ]; then
        echo "| $sname | skipped: \`$MESHRAD_SCENES/$mesh\` missing | | | | | | | | | |" >>"$report"
        continue
      fi
    fi
    cpu="$out/cpu/$sname"
    mkdir -p "$out/cpu"
    if [ ! -f "$cpu/total.exr" ]; then
      solve "$file" cpu "" "$cpu"
      cpu_wall=$wall
      echo "$cpu_wall" >"$cpu.wall"
      if [ "$code" != 0 ]; then
        echo "| $sname | **FAIL**: the CPU solve exited $code (\`$cpu.log\`) | | | | | | | | | |" >>"$report"
        failed=1
        continue
      fi
    fi
    cpu_wall=$(cat "$cpu.wall")
    solve "$file" gpu "$dev" "$d/$sname"
    if [ "$code" != 0 ]; then
      echo "| $sname | **FAIL**: the device solve exited $code (\`$d/$sname.log\`) | | | | $cpu_wall s | $wall s | | | | |" >>"$report"
      failed=1
      continue
    fi
    compare "$d/$sname" "$cpu"
    t=${vals[0]} dr=${vals[1]} ind=${vals[2]}
    verrs=$(stat "$d/$sname/stats.json" validation_errors)
    result=pass
    if [ "$same" != 1 ] || [ "${verrs:-0}" != 0 ]; then
      result="**FAIL**"
      failed=1
    fi
    # The image must have been drawn on the device (kernel `image`), not on the CPU.
    if grep -q '"drawn_on": *"device"' "$d/$sname/stats.json"; then
      img=$(awk -v k="$(stat "$d/$sname/stats.json" image_kernel)" -v t="$(stat "$d/$sname/stats.json" image_pass)" \
        'BEGIN { printf "%.3f / %.3f s", k, t }')
    else
      img="**not on the device**"
      result="**FAIL**"
      failed=1
    fi
    printf '| %s | %s | %s | %s | %s | %s s | %s s | %s s | %s | %s | %s |\n' "$sname" "$result" "$t" "$dr" "$ind" \
      "$cpu_wall" "$wall" "$(awk -v s="$(stat "$d/$sname/stats.json" solve)" 'BEGIN { printf "%.2f", s }')" \
      "$img" "${verrs:-?}" "$(kernels "$d/$sname.log")" >>"$report"
  done

  # An animate sequence: every frame on the device against the CPU's.
  frames=scenes/cornell_frames.toml
  if [ ! -d "$out/cpu/animate/0000" ]; then
    "$BIN" animate scenes/cornell_parts.toml --frames "$frames" --out "$out/cpu/animate" --backend cpu -q \
      --exposure 0 "${settings[@]}" >"$out/cpu/animate.log" 2>&1
  fi
  t0=$(now)
  "$BIN" animate scenes/cornell_parts.toml --frames "$frames" --out "$d/animate" --backend gpu --device "$dev" \
    --exposure 0 "${settings[@]}" >"$d/animate.log" 2>&1
  code=$?
  wall=$(elapsed "$t0" "$(now)")
  worst=0
  result=pass
  n=0
  for f in "$out"/cpu/animate/[0-9]*; do
    k=$(basename "$f")
    n=$((n + 1))
    compare "$d/animate/$k" "$f"
    t=${vals[0]}
    [ "$same" = 1 ] || result="**FAIL**"
    worst=$(awk -v a="$worst" -v b="$t" 'BEGIN { print (b + 0 > a + 0 || b == "error") ? b : a }')
  done
  if [ "$code" != 0 ] || [ "$n" = 0 ]; then
    result="**FAIL**: exit $code, $n frames (\`$d/animate.log\`)"
  fi
  [ "$result" = pass ] || failed=1
  echo "| animate ($n frames, worst frame) | $result | $worst | | | | $wall s | | | | |" >>"$report"

  # The paper's Table 2 on this device.
  t2=(bench table2 --device "$dev" --out "$d/table2" -q)
  [ "$smoke" = 1 ] && t2+=(--smoke --scenes cornell)
  t0=$(now)
  "$BIN" "${t2[@]}" >"$d/table2.log" 2>&1
  code=$?
  wall=$(elapsed "$t0" "$(now)")
  if [ "$code" = 0 ]; then
    echo "| bench table2$([ "$smoke" = 1 ] && echo ' --smoke') | pass | | | | | $wall s | | | | |" >>"$report"
  else
    echo "| bench table2 | **FAIL**: exit $code (\`$d/table2.log\`) | | | | | $wall s | | | | |" >>"$report"
    failed=1
  fi
  {
    echo
    if [ -f "$d/table2/table2.md" ]; then
      echo "### bench table2 on device $dev"
      echo
      cat "$d/table2/table2.md"
      echo
    fi
  } >>"$report"
done

{
  echo
  echo "Columns: total, direct, indirect are the relative RMS of the device's image against the CPU's;"
  echo "end to end is the wall time of the whole command (load to written outputs); device solve is"
  echo "stats.json's \`seconds.solve\`; the device image is drawn where the device solved (kernel \`image\`):"
  echo "its kernel time (GPU timestamps) and the whole pass (stats.json \`image.device_seconds\`);"
  echo "kernel times are what \`--stats\` printed."
  echo
  [ "$failed" = 0 ] && echo "**All checks passed.**" || echo "**Some checks failed.**"
} >>"$report"
cat "$report"
exit "$failed"
