#!/bin/bash
# rt_gpu_exports.sh: the exports (`nimbus export-glsl`) that tests/bench/rt_gpu_run.sh times on
# a machine with a GPU, written here (where Nimbus and its data are) into one folder that can be
# copied there: a GPU server needs only nimbus_headless (EGL + libOpenGL) and this folder.
# Data files shared by several exports (noise textures, majorant grids) are stored once under
# store/ and listed in links.txt; rt_gpu_run.sh links them back.
#   [ONLY=REGEX] tests/bench/rt_gpu_exports.sh build/nimbus OUT_DIR
# The set: the default scene as shipped (diffusion grid) and with multiple scattering off, at
# 1280x720 and 1920x1080; at 1920x1080 also the noise evaluated directly, empty-space skipping
# off, and the step schedule x2 and x4 (what temporal accumulation renders per frame); smoke1 as
# shipped at both sizes; the same with render.shadow = "volume" (the light-attenuation volume)
# and its step multiples; the SDF cloud and the dragon; at 480x270 the accuracy set (one sample
# per pixel, step x1 to x4, shadow marches and the light volume) that rt_gpu_accuracy.py
# compares with the CPU; the default scene and smoke1 with render.forward_scattering = "none"
# (what the forward peak kept in the beams costs). The dragon needs the shared data folder
# beside the repository. ONLY=REGEX: only the exports whose name matches (the folder stays
# small enough for one transfer).
set -euo pipefail
nimbus=${1:?usage: rt_gpu_exports.sh path/to/nimbus OUT_DIR}
out=${2:?usage: rt_gpu_exports.sh path/to/nimbus OUT_DIR}
here=$(cd "$(dirname "$0")/../.." && pwd)
cumulus="$here/examples/scenes/cumulus.toml"
smoke1="$here/examples/scenes/smoke1.toml"
rm -rf "$out"
mkdir -p "$out/store"
steps() { # the step schedule scaled by $1 (as rt_accumulate.sh)
    python3 -c "m=float('$1'); print(f'render.step={0.04*m:.9g} render.step_growth={0.004*m:.9g} render.shadow_step={0.05*m:.9g}')"
}
export_one() { # NAME SCENE WxH [--set k=v ...]
    local name=$1 scene=$2 size=$3
    shift 3
    [[ -z ${ONLY:-} || $name =~ $ONLY ]] || return 0
    "$nimbus" export-glsl "$scene" -o "$out/$name" --set "camera.width=${size%x*}" \
        --set "camera.height=${size#*x}" --set 'output.preview=""' "$@" >/dev/null 2>"$out/$name.log" ||
        { cat "$out/$name.log" >&2; exit 1; }
    rm -f "$out/$name.log"
    echo "$name: $(du -sh "$out/$name" | cut -f1)"
}
nomS=(--set 'render.multiple_scattering="none"')
nofwd=(--set 'render.forward_scattering="none"')
direct=(--set 'field.evaluation="direct"' --set 'render.pixel_samples=1')
for size in 1280x720 1920x1080; do
    export_one "cumulus_${size}" "$cumulus" "$size"
    export_one "cumulus_noms_${size}" "$cumulus" "$size" "${nomS[@]}"
    export_one "smoke1_${size}" "$smoke1" "$size"
    export_one "cumulus_nofwd_${size}" "$cumulus" "$size" "${nofwd[@]}"
    export_one "smoke1_nofwd_${size}" "$smoke1" "$size" "${nofwd[@]}"
done
export_one cumulus_noms_direct_1920x1080 "$cumulus" 1920x1080 "${nomS[@]}" --set 'field.evaluation="direct"'
export_one cumulus_noms_noskip_1920x1080 "$cumulus" 1920x1080 "${nomS[@]}" --set 'render.skip_empty=false'
for m in 1 2 4; do
    sets=()
    for kv in $(steps "$m"); do sets+=(--set "$kv"); done
    export_one "cumulus_noms_direct_m${m}_1920x1080" "$cumulus" 1920x1080 "${nomS[@]}" "${direct[@]}" "${sets[@]}"
    export_one "acc_m${m}_480x270" "$cumulus" 480x270 "${nomS[@]}" "${direct[@]}" "${sets[@]}"
done
export_one cumulus_480x270 "$cumulus" 480x270
export_one smoke1_480x270 "$smoke1" 480x270
# render.shadow = "volume": the sun's light-attenuation volume instead of a shadow march per
# sample (RT_LIGHT_VOLUME): the default scene as shipped otherwise, at both sizes and with the
# step schedule x2 and x4 at 1920x1080; baked noise with shadow marches at x2 and x4 to compare;
# smoke1; and the accuracy set at 480x270 (one sample per pixel)
volume=(--set 'render.shadow="volume"')
for size in 1280x720 1920x1080; do
    export_one "cumulus_volume_${size}" "$cumulus" "$size" "${volume[@]}"
    export_one "smoke1_volume_${size}" "$smoke1" "$size" "${volume[@]}"
done
# the step multiples keep the light volume's voxel (which the diffusion grid shares) at the
# m = 1 plan's 0.234375: the plan would otherwise coarsen it with the step
cell=(--set render.light_volume_cell=0.234375)
for m in 1 1.5 1.75 2 4; do
    sets=()
    for kv in $(steps "$m"); do sets+=(--set "$kv"); done
    if [ "$m" != 1 ]; then
        export_one "cumulus_volume_m${m}_1920x1080" "$cumulus" 1920x1080 "${volume[@]}" "${cell[@]}" "${sets[@]}"
        export_one "cumulus_m${m}_1920x1080" "$cumulus" 1920x1080 "${sets[@]}"
    fi
    [ "$m" != 1.5 ] || export_one "cumulus_volume_nofwd_m${m}_1920x1080" "$cumulus" 1920x1080 \
        "${volume[@]}" "${cell[@]}" "${nofwd[@]}" "${sets[@]}"
    export_one "acc_volume_m${m}_480x270" "$cumulus" 480x270 "${volume[@]}" "${cell[@]}" --set 'render.pixel_samples=1' "${sets[@]}"
done
export_one cumulus_volume_480x270 "$cumulus" 480x270 "${volume[@]}"
export_one smoke1_volume_480x270 "$smoke1" 480x270 "${volume[@]}"
# the SDF cloud (as it ships: the light volume; and with shadow marches) and the dragon (a
# production VDB, the shared data folder; as it ships: shadow marches, no multiple scattering;
# and with the light volume)
sdf="$here/examples/scenes/sdf_cloud.toml"
dragon="$here/examples/scenes/dragon.toml"
for size in 1280x720 1920x1080; do
    export_one "sdf_cloud_${size}" "$sdf" "$size"
    export_one "dragon_${size}" "$dragon" "$size"
    export_one "dragon_volume_${size}" "$dragon" "$size" "${volume[@]}"
done
export_one sdf_cloud_march_1920x1080 "$sdf" 1920x1080 --set 'render.shadow="march"'
# data files stored once: store/<sha256>, links.txt lines "<export>/<file> <sha256>"
: >"$out/links.txt"
for f in "$out"/*/*.bin; do
    case $f in */params.bin) continue ;; esac
    sum=$(sha256sum "$f" | cut -c1-64)
    [ -e "$out/store/$sum" ] || mv "$f" "$out/store/$sum"
    rm -f "$f"
    echo "${f#"$out"/} $sum" >>"$out/links.txt"
done
echo "$(ls "$out" | grep -vc -e store -e links.txt) exports, store $(du -sh "$out/store" | cut -f1)"
