#!/usr/bin/env bash
# The cost of motion blur (docs/motion_blur.md): frame 1 of the default scene, one thread, blurred
# and unblurred runs interleaved; prints "label user_s sys_s wall_s" per run (GNU time). march:
# 320x180, render.pixel_samples = 4; pathtrace: 160x90, 16 spp. The scene's own wind with a
# shutter of [-0.25, 0.25], and a wind of [12, 0, 3] km/s with [-0.5, 0.5].
#
#   tests/bench/motion_blur.sh [REPEATS]    # default 4; needs build/nimbus and /usr/bin/time
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
n="${1:-4}"
nimbus="$root/build/nimbus"
[ -x "$nimbus" ] || { echo "motion_blur.sh: build nimbus first ($nimbus)" >&2; exit 2; }
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
run() { # label, then overrides
    local label=$1
    shift
    /usr/bin/time -f "%U %S %e" -o "$tmp/t" "$nimbus" render "$root/examples/scenes/cumulus.toml" \
        --frames 1 -q -t 1 --set 'output.aovs=[]' --set 'output.preview=""' "$@" \
        -o "$tmp/f.####.exr" >/dev/null 2>&1
    echo "$label $(cat "$tmp/t")"
}
M=(--set camera.width=320 --set camera.height=180 --set render.pixel_samples=4)
P=(--set camera.width=160 --set camera.height=90 --set 'render.integrator="pathtrace"'
    --set render.spp=16)
W=(--set 'field.wind=[12,0,3]')
for _ in $(seq "$n"); do
    run march_off "${M[@]}"
    run march_on "${M[@]}" --set 'render.shutter=[-0.25,0.25]'
    run march_strong_off "${M[@]}" "${W[@]}"
    run march_strong_on "${M[@]}" "${W[@]}" --set 'render.shutter=[-0.5,0.5]'
    run pt_off "${P[@]}"
    run pt_on "${P[@]}" --set 'render.shutter=[-0.25,0.25]'
    run pt_strong_off "${P[@]}" "${W[@]}"
    run pt_strong_on "${P[@]}" "${W[@]}" --set 'render.shutter=[-0.5,0.5]'
done
