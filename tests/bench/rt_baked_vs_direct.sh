#!/bin/bash
# rt_baked_vs_direct.sh: frame time of the GLSL march pass (`nimbus rt`) with the cumulus noise
# read from the tiles the CPU baked (field.evaluation = "baked", RT_BAKED_NOISE) against the
# noise evaluated per sample ("direct"), runs interleaved (baked, direct, baked, direct, ...), on
# the default scene with multiple scattering off. Prints every run's time and the medians.
#   tests/bench/rt_baked_vs_direct.sh build/nimbus [WIDTHxHEIGHT] [ROUNDS] [FRAME] [--set ...]
# Time: what `nimbus rt` prints per frame (parameter and tile upload, dispatch, wait and
# read-back); the shader compile, the context and the CPU's bake of the tiles are apart (each
# run is a new process, so every baked run bakes the tiles on the CPU first: not timed here).
set -euo pipefail
nimbus=${1:?usage: rt_baked_vs_direct.sh path/to/nimbus [WxH] [rounds] [frame] [--set k=v ...]}
size=${2:-160x90}
rounds=${3:-3}
frame=${4:-1}
shift $(( $# < 4 ? $# : 4 ))
. "$(dirname "$0")/rt_bench_common.sh"
rt_bench_init "$size"
sets=(--set "camera.width=$w" --set "camera.height=$h" --set 'render.multiple_scattering="none"'
      --set "output.preview=\"\"" "$@")
baked=()
direct=()
frameTime() {
    "$nimbus" rt "$scene" --frames "$frame" -o "$tmp/$1.####.exr" "${sets[@]}" 2>/dev/null \
        --set "field.evaluation=\"$1\"" |
        rt_gpu_seconds
}
for r in $(seq 1 "$rounds"); do
    b=$(frameTime baked)
    d=$(frameTime direct)
    echo "round $r: baked $b s, direct $d s"
    baked+=("$b")
    direct+=("$d")
done
rt_medians baked "${baked[*]}" direct "${direct[*]}"
