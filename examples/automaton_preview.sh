#!/usr/bin/env bash
# Renders the automaton cumulus sequence (examples/scenes/automaton_cumulus.toml, 96 frames) and
# makes a PNG contact sheet of every 8th frame, out/automaton_contact.png, with ImageMagick's
# montage; GIF=1 also writes an animated preview, out/automaton_cumulus.gif; RENDER=0 reuses the
# frames already in out/. Builds nimbus when build/nimbus is missing. Extra arguments go to
# `nimbus render` (e.g. --frames 1-24).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
if [ ! -x build/nimbus ]; then
  bash examples/install_deps.sh
  cmake -S . -B build -DCMAKE_BUILD_TYPE=Release
  cmake --build build -j2 --target nimbus
fi
command -v montage >/dev/null || { echo "montage not found: bash examples/install_deps.sh" >&2; exit 1; }
if [ "${RENDER:-1}" != 0 ]; then
  ./build/nimbus render examples/scenes/automaton_cumulus.toml "$@"
fi
frames=()
for f in $(seq 1 8 96) 96; do
  png=$(printf "out/automaton_cumulus.%04d.png" "$f")
  [ -f "$png" ] && frames+=(-label "frame $f" "$png")
done
[ ${#frames[@]} -gt 0 ] || { echo "no PNG previews in out/" >&2; exit 1; }
montage "${frames[@]}" -tile 4x -geometry 240x135+3+3 -font DejaVu-Sans -pointsize 12 \
  out/automaton_contact.png
echo "contact sheet: $root/out/automaton_contact.png"
if [ "${GIF:-0}" = 1 ]; then
  montage_in=(out/automaton_cumulus.[0-9][0-9][0-9][0-9].png)
  convert -delay 4 -loop 0 "${montage_in[@]}" -resize 50% out/automaton_cumulus.gif
  echo "animation: $root/out/automaton_cumulus.gif"
fi
