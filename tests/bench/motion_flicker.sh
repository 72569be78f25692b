#!/usr/bin/env bash
# Flicker against true motion on an animated sequence (docs/temporal.md): a cumulus layer carried
# by [field.advect] with a uniform wind of exactly one advection cell per frame, seen from far
# away through a narrow lens so that the motion is a shift of 2 pixels per frame across the
# image (to within 2% over the cloud's depth). For march as shipped ("march": jitter and
# render.multiple_scattering = "auto", which takes photons below an optical depth of 64 along the
# sun), march with the diffusion grid named ("grid"), photons on the light-volume grid at 200,000
# ("photons", the row before "auto") and pathtrace, with render.seed_per_frame true and false,
# prints the relative RMS difference over
# RGB of consecutive frames as rendered ("raw": motion + noise) and after warping the earlier
# frame by the known motion ("warped": what is left is noise and what the frame-fixed lighting
# grids change as the cloud crosses them), over frames 1-4, and the seconds per frame.
# MARCH_SET="key=value;key=value" adds settings to the "march" row (e.g. render.photons=8000000).
#
#   tests/bench/motion_flicker.sh          # needs build/nimbus and oiiotool
#   SIGMA=0.8 tests/bench/motion_flicker.sh  # the cloud 10x thinner (default medium.sigma_s 8:
#                                            # optical depth about 8 along the sun; 0.8: 0.8)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
nimbus="${NIMBUS:-$root/build/nimbus}" # NIMBUS=path: another build
[ -x "$nimbus" ] || { echo "motion_flicker.sh: build nimbus first ($nimbus)" >&2; exit 2; }
command -v oiiotool >/dev/null || { echo "motion_flicker.sh: oiiotool not found" >&2; exit 2; }
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
W=320; H=180; SHIFT=-2   # the cloud moves to +x, which is to the left in this view
# 0.05 units per pixel at the distance 150: tan(fov / 2) = 0.05 x 180 / 300
SIGMA="${SIGMA:-8.0}"
cat > "$out/scene.toml" <<TOML
frames = "1-4"
[camera]
position = [0.0, 3.0, -150.0]
look_at = [0.0, 3.0, 0.0]
fov = 3.4369   # degrees: 2 atan(0.03)
width = 320
height = 180
[sun]
elevation = 25.0
azimuth = 70.0
intensity = 4.0
[sky]
kind = "gradient"
horizon = [0.25, 0.35, 0.55]   # darker than the clouds: their edges show
[medium]
sigma_s = $SIGMA
[field]
kind = "cumulus"
bounds_min = [-12.0, 1.5, -3.0]
bounds_max = [12.0, 4.5, 3.0]
[field.advect]
voxel = 0.1
scheme = "semi_lagrangian"   # whole-cell shifts are exact: no diffusion in the motion
wind = [2.4, 0.0, 0.0]        # 0.1 units (one cell, 2 pixels) per frame at 24 fps
[render]
spp = 4
TOML
relrms() { # relative RMS difference of two EXRs over RGB; $3 = x shift of the second (pixels)
    local a="$1" b="$2" s="$3" rms avg xa=0 xb=0
    if [ "$s" -ge 0 ]; then xb=$s; else xa=$((-s)); s=$((-s)); fi
    rms=$(oiiotool "$a" --ch R,G,B --cut "$((W - s))x${H}+${xa}+0" "$b" --ch R,G,B \
        --cut "$((W - s))x${H}+${xb}+0" --diff 2>&1 | awk '/RMS error/ {print $4}')
    avg=$(oiiotool --stats "$a" 2>&1 | awk '/Stats Avg/ {print ($3 + $4 + $5) / 3}')
    awk -v r="$rms" -v a="$avg" 'BEGIN {printf "%.4f", r / a}'
}
mean3() { awk -v a="$1" -v b="$2" -v c="$3" 'BEGIN {printf "%.4f", (a + b + c) / 3}'; }
# "exact": march without jitter and without lighting grids (shadow rays only): no noise and
# nothing fixed to the world, so its warped figure is the floor of the measurement (the 2% of
# shift that varies over the cloud's depth, and resampling at sub-pixel edges)
declare -A methods=([exact]="render.jitter=false;render.multiple_scattering=\"none\""
    [march]="${MARCH_SET:-}" [grid]="render.multiple_scattering=\"grid\""
    [photons]="render.multiple_scattering=\"photons\";render.photons=200000;render.photon_cell_scale=1"
    [pathtrace]="render.integrator=\"pathtrace\"")
printf '%-10s %-15s %10s %10s %10s\n' method seed_per_frame raw warped s/frame
for m in exact march grid photons pathtrace; do
    for per in true false; do
        extra=()
        IFS=';' read -r -a sets <<< "${methods[$m]}"
        for kv in "${sets[@]}"; do [ -n "$kv" ] && extra+=(--set "$kv"); done
        t0=$(date +%s.%N)
        "$nimbus" render "$out/scene.toml" -o "$out/$m.$per.####.exr" "${extra[@]}" \
            --set "render.seed_per_frame=$per" >/dev/null 2>&1
        t1=$(date +%s.%N)
        raw=(); warped=()
        for f in 1 2 3; do
            a=$(printf "%s/%s.%s.%04d.exr" "$out" "$m" "$per" "$f")
            b=$(printf "%s/%s.%s.%04d.exr" "$out" "$m" "$per" "$((f + 1))")
            raw+=("$(relrms "$a" "$b" 0)")
            warped+=("$(relrms "$a" "$b" "$SHIFT")")
        done
        printf '%-10s %-15s %10s %10s %10s\n' "$m" "$per" "$(mean3 "${raw[@]}")" \
            "$(mean3 "${warped[@]}")" "$(awk -v t0="$t0" -v t1="$t1" 'BEGIN {printf "%.1f", (t1 - t0) / 4}')"
    done
done
