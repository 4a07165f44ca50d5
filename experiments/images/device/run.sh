#!/usr/bin/env bash
# Issue #33: one scene solved and drawn on the CPU backend and on a Vulkan device, each
# run alone; the image pass's time (stats.json `seconds.output`, and on the device
# `image.device_seconds`: the `image` kernel and the whole pass) beside the end-to-end
# wall time, and the device's images against the CPU's (`meshrad bench compare`).
# Usage (from the repository root):
#   bash experiments/images/device/run.sh SCENE OUT_DIR BIN [DEVICE]
set -euo pipefail
[ $# -ge 3 ] || { sed -n '2,7p' "$0" >&2; exit 2; }
scene=$1 out=$2 bin=$3 dev=${4:-}
mkdir -p "$out"
run() {
  local label=$1; shift
  local t0 t1
  t0=$(date +%s.%N)
  "$bin" solve "$scene" --out "$out/$label" --stats -q "$@" >"$out/$label.log" 2>&1
  t1=$(date +%s.%N)
  python3 - "$out/$label/stats.json" "$label" "$t0" "$t1" <<'PY'
import json, sys
s = json.load(open(sys.argv[1])); sec = s["seconds"]; im = s["image"]
dev = im.get("device_seconds")
print(f"{sys.argv[2]}: {im['width']}x{im['height']} {im['spp']} spp on {im['drawn_on']}; "
      f"end to end {float(sys.argv[4]) - float(sys.argv[3]):.1f} s (load {sec['load']:.1f}, hierarchy {sec['hierarchy']:.1f}, "
      f"solve {sec['solve']:.1f}, output {sec['output']:.1f})"
      + (f"; image kernel {dev['image_kernel']:.1f} s, image pass {dev['image_pass']:.1f} s" if dev else "")
      + f"; doubted samples {im['doubted_samples']}, basis {im['basis_samples']}")
PY
}
run cpu --backend cpu
args=(--backend gpu)
[ -n "$dev" ] && args+=(--device "$dev")
run device "${args[@]}"
for f in direct indirect total; do
  echo "$f: device against CPU: $("$bin" bench compare "$out/device/$f.exr" "$out/cpu/$f.exr")"
done
