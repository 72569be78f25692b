#!/usr/bin/env bash
# Renders an animated example scene and makes a PNG contact sheet of every 8th frame with
# ImageMagick's montage:
#   bash examples/preview.sh examples/scenes/advected_smoke.toml [nimbus render arguments]
# The scene's previews must be out/<name>.####.png (as in examples/scenes/*.toml); the sheet is
# out/<name>_contact.png. GIF=1 also writes an animated preview, out/<name>.gif, of the PNGs
# present; RENDER=0 reuses the frames already in out/; without arguments after the scene, only
# every 8th frame (and the last) is rendered, enough for the sheet. Builds nimbus when
# build/nimbus is missing.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
[ $# -ge 1 ] || { echo "usage: bash examples/preview.sh SCENE.toml [nimbus render args]" >&2; exit 2; }
scene="$1"; shift
name="$(basename "$scene" .toml)"
if [ ! -x build/nimbus ]; then
  bash examples/install_deps.sh
  cmake -S . -B build -DCMAKE_BUILD_TYPE=Release
  cmake --build build -j2 --target nimbus
fi
command -v montage >/dev/null || { echo "montage not found: bash examples/install_deps.sh" >&2; exit 1; }
# the last frame of the scene's `frames` spec (a plain range such as "1-96")
last=$(sed -n 's/^frames *= *"\(.*\)".*/\1/p' "$scene" | grep -oE '[0-9]+' | tail -n 1 || true)
[[ "$last" =~ ^[0-9]+$ ]] || last=1
if [ "${RENDER:-1}" != 0 ]; then
  if [ $# -gt 0 ]; then
    ./build/nimbus render "$scene" "$@"
  else
    ./build/nimbus render "$scene" --frames "1-${last}x8,${last}"
  fi
fi
frames=()
for f in $(seq 1 8 "$last") "$last"; do
  png=$(printf "out/%s.%04d.png" "$name" "$f")
  [ -f "$png" ] && frames+=(-label "frame $f" "$png")
done
[ ${#frames[@]} -gt 0 ] || { echo "no PNG previews out/$name.####.png" >&2; exit 1; }
montage "${frames[@]}" -tile 4x -geometry 240x135+3+3 -font DejaVu-Sans -pointsize 12 \
  "out/${name}_contact.png"
echo "contact sheet: $root/out/${name}_contact.png"
if [ "${GIF:-0}" = 1 ]; then
  pngs=(out/"$name".[0-9][0-9][0-9][0-9].png)
  convert -delay 4 -loop 0 "${pngs[@]}" -resize 50% "out/$name.gif"
  echo "animation: $root/out/$name.gif"
fi
