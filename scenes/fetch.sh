#!/usr/bin/env bash
# Fetches public scenes to try meshrad on (issue #34's real assets), each with a scene
# file that lights it by a sun and a sky and frames it with the default camera:
#   bash scenes/fetch.sh            lists them
#   bash scenes/fetch.sh NAME...    downloads NAME into $MESHRAD_SCENES/public/NAME/
#                                   (default ../shared/scenes/public) and writes NAME.toml
# then: meshrad solve $MESHRAD_SCENES/public/NAME/NAME.toml
#   PBRSCENES=DIR bash scenes/fetch.sh staircase   converts from a local checkout of
#                                   github.com/Zielon/PBRScenes instead of downloading
# glTF models come from the Khronos glTF Sample Assets repository (VC from the older
# glTF-Sample-Models); each keeps its own licence (listed here and in that repository's
# Models/NAME/README.md). McGuire's
# Computer Graphics Archive (Sibenik, Conference, Lost Empire, the sports car) offers its
# zips through a web page only: the list names it, and a scene file for an OBJ you have
# unzipped is one `[[object]] mesh = "…obj"` line.
# Written without network access: the download address is printed before each download
# so that a moved file is easy to find by hand.
set -euo pipefail
base=https://raw.githubusercontent.com/KhronosGroup/glTF-Sample-Assets/main/Models
# name | file in the repository | licence: read Models/NAME/README.md there before you use
# one beyond trying it (BoxTextured's was checked in the older glTF-Sample-Models; the
# others are as recalled)
models=(
  "DamagedHelmet|DamagedHelmet/glTF-Binary/DamagedHelmet.glb|CC-BY 4.0, theblueturtle_ (see its README)"
  "BoomBox|BoomBox/glTF-Binary/BoomBox.glb|donated by Microsoft for glTF testing (see its README)"
  "Lantern|Lantern/glTF-Binary/Lantern.glb|donated by Microsoft for glTF testing (see its README)"
  "BoxTextured|BoxTextured/glTF-Binary/BoxTextured.glb|CC-BY 4.0, Cesium (also in tests/data/)"
  "AlphaBlendModeTest|AlphaBlendModeTest/glTF-Binary/AlphaBlendModeTest.glb|see its README"
  "Sponza|Sponza/glTF/Sponza.gltf|CC-BY 3.0, Frank Meinl, Crytek (see its README)"
  "VC|https://raw.githubusercontent.com/KhronosGroup/glTF-Sample-Models/main/2.0/VC/glTF-Binary/VC.glb|by 3DRT, for testing glTF tools only, not for commercial use (see its README); a city inside a skybox: meshrad names the skybox node to leave out"
)
# Interiors lit by lights inside them, from github.com/Zielon/PBRScenes (a collection
# for a Vulkan path tracer of scenes after Benedikt Bitterli's rendering resources,
# https://benedikt-bitterli.me/resources/, where each scene's author and licence are
# listed). Set PBRSCENES to a local checkout of that repository to convert without
# downloading.
pbr=https://raw.githubusercontent.com/Zielon/PBRScenes/main
interiors=(
  "staircase|Staircase by Wig42 after Bitterli's resources (see that page for its licence)"
)
root=${MESHRAD_SCENES:-$(cd "$(dirname "$0")/.." && pwd)/../shared/scenes}/public
if [ $# = 0 ]; then
  echo "glTF models (Khronos glTF Sample Assets, $base):"
  for m in "${models[@]}"; do IFS='|' read -r name file lic <<<"$m"; printf '  %-20s %s\n' "$name" "$lic"; done
  echo "OBJ scenes by hand from McGuire's Computer Graphics Archive, https://casual-effects.com/data/"
  echo "  (Sibenik, Conference, Lost Empire, sportsCar: each zip's licence is on that page)"
  echo "Interiors (Tinsel .scene files, converted by scenes/tinsel2meshrad.py; issue #32):"
  for m in "${interiors[@]}"; do IFS='|' read -r name lic <<<"$m"; printf '  %-20s %s\n' "$name" "$lic"; done
  echo "into: $root"
  exit 0
fi
command -v curl >/dev/null || { echo "fetch.sh: needs curl" >&2; exit 1; }
fetch_interior() { # NAME DIR: the .scene file and every file it names, then converted
  local name=$1 dir=$2 src=$2/source f
  mkdir -p "$src"
  if [ -n "${PBRSCENES:-}" ]; then
    cp "$PBRSCENES/$name.scene" "$src/"
  else
    echo "fetch.sh: $name from $pbr/$name.scene"
    curl -fsSL "$pbr/$name.scene" -o "$src/$name.scene"
  fi
  awk 'tolower($1) == "file" || tolower($1) == "albedotexture" { print $2 }' "$src/$name.scene" | sort -u |
    while read -r f; do
      mkdir -p "$src/$(dirname "$f")"
      if [ -n "${PBRSCENES:-}" ]; then
        cp "$PBRSCENES/$f" "$src/$f" 2>/dev/null || echo "fetch.sh: $PBRSCENES/$f is missing" >&2
      else
        curl -fsSL "$pbr/$f" -o "$src/$f.part" && mv "$src/$f.part" "$src/$f" ||
          echo "fetch.sh: $pbr/$f could not be fetched" >&2
      fi
    done
  python3 "$(dirname "$0")/tinsel2meshrad.py" "$src/$name.scene" "$dir" "$name"
  echo "fetch.sh: wrote $dir/$name.toml"
}
for want in "$@"; do
  found=""
  for m in "${interiors[@]}"; do
    IFS='|' read -r name lic <<<"$m"
    [ "$name" = "$want" ] || continue
    found=1
    echo "fetch.sh: $name ($lic)"
    fetch_interior "$name" "$root/$name"
  done
  for m in "${models[@]}"; do
    IFS='|' read -r name file lic <<<"$m"
    [ "$name" = "$want" ] || continue
    found=1
    dir=$root/$name; mkdir -p "$dir"
    case $file in https://*) url=$file ;; *) url=$base/$file ;; esac
    echo "fetch.sh: $name ($lic) from $url"
    if [ "${file##*.}" = gltf ]; then
      # A .gltf names its buffers and images: fetch them from the same folder.
      curl -fsSL "$url" -o "$dir/$name.gltf.part"
      mv "$dir/$name.gltf.part" "$dir/$name.gltf"
      python3 -c 'import json,sys; j=json.load(open(sys.argv[1])); print("\n".join(x["uri"] for k in ("buffers","images") for x in j.get(k,[]) if "uri" in x and not x["uri"].startswith("data:")))' \
        "$dir/$name.gltf" | while read -r uri; do
          mkdir -p "$dir/$(dirname "$uri")"
          curl -fsSL "$(dirname "$url")/$uri" -o "$dir/$uri.part" && mv "$dir/$uri.part" "$dir/$uri"
        done
      mesh=$name.gltf
    else
      curl -fsSL "$url" -o "$dir/$name.glb.part"
      mv "$dir/$name.glb.part" "$dir/$name.glb"
      mesh=$name.glb
    fi
    cat > "$dir/$name.toml" <<T
# $name ($lic; $url), under a sun and a sky, framed by the default camera.
[[object]]
mesh = "$mesh"

[[light]]
type = "directional"
direction = [-0.4, -1.0, -0.6]
irradiance = [3.0, 3.0, 3.0]

[sky]
radiance = [0.3, 0.3, 0.3]
T
    echo "fetch.sh: wrote $dir/$name.toml"
  done
  [ -n "$found" ] || { echo "fetch.sh: no model $want (bash scenes/fetch.sh lists them)" >&2; exit 2; }
done
