#!/usr/bin/env bash
# Temporal stability on a static shot (docs/temporal.md): the default scene with its wind set
# to 0, three frames per method (march with the diffusion grid and jitter, march with photons,
# pathtrace), with each frame's own seeds (render.seed_per_frame = true, the default) and with one
# seed for every frame (false). Prints the frame-to-frame relative RMS difference over RGB
# (oiiotool --diff's RMS error over the mean of the colour channels), averaged over frames 1-2
# and 2-3, and the seconds per frame.
#
#   tests/bench/flicker.sh [WIDTH HEIGHT]    # default 320 180; needs build/nimbus and oiiotool
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
w="${1:-320}"
h="${2:-180}"
nimbus="$root/build/nimbus"
[ -x "$nimbus" ] || { echo "flicker.sh: build nimbus first ($nimbus)" >&2; exit 2; }
command -v oiiotool >/dev/null || { echo "flicker.sh: oiiotool not found (apt install openimageio-tools)" >&2; exit 2; }
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
static=(--set "field.wind=[0,0,0]" --set "field.detail_wind=[0,0,0]" --set "camera.width=$w"
    --set "camera.height=$h")
declare -A methods=(
    [march]=""
    [photons]="render.multiple_scattering=\"photons\""
    [pathtrace]="render.integrator=\"pathtrace\""
)
relrms() { # relative RMS difference of two EXRs over RGB
    local rms avg
    rms=$(oiiotool "$1" --ch R,G,B "$2" --ch R,G,B --diff 2>&1 | awk '/RMS error/ {print $4}')
    avg=$(oiiotool --stats "$1" 2>&1 | awk '/Stats Avg/ {print ($3 + $4 + $5) / 3}')
    awk -v r="$rms" -v a="$avg" 'BEGIN {printf "%.4f", r / a}'
}
printf '%-10s %-15s %12s %10s\n' method seed_per_frame flicker s/frame
for m in march photons pathtrace; do
    for per in true false; do
        extra=()
        [ -n "${methods[$m]}" ] && extra=(--set "${methods[$m]}")
        t0=$(date +%s.%N)
        "$nimbus" render "$root/examples/scenes/cumulus.toml" --frames 1-3 \
            -o "$out/$m.$per.####.exr" "${static[@]}" "${extra[@]}" \
            --set "render.seed_per_frame=$per" >/dev/null 2>&1
        t1=$(date +%s.%N)
        a=$(relrms "$out/$m.$per.0001.exr" "$out/$m.$per.0002.exr")
        b=$(relrms "$out/$m.$per.0002.exr" "$out/$m.$per.0003.exr")
        printf '%-10s %-15s %12s %10s\n' "$m" "$per" "$(awk -v a="$a" -v b="$b" 'BEGIN {printf "%.4f", (a + b) / 2}')" \
            "$(awk -v t0="$t0" -v t1="$t1" 'BEGIN {printf "%.1f", (t1 - t0) / 3}')"
    done
done
