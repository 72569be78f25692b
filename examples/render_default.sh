#!/usr/bin/env bash
# Installs what is missing, builds Nimbus (Release, -j2) and renders the default scene: 24 frames
# of procedural cumulus drifting in the wind, to out/cumulus.####.exr (+ PNG previews).
# Extra arguments go to `nimbus render` (e.g. --frames 1-4).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
bash examples/install_deps.sh
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release
cmake --build build -j2 --target nimbus
./build/nimbus render examples/scenes/cumulus.toml "$@"
echo "frames written to $root/out/ (EXR in ACEScg; PNG previews through sRGB / ACES 1.0 SDR-video)"
