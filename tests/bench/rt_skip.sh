#!/bin/bash
# rt_skip.sh: frame time of the GLSL march pass (`nimbus rt`) with empty-space skipping over the
# frame's majorant grid (RT_SKIP) against without (render.skip_empty = false: no grid, every step
# in the field's box taken), runs interleaved (skip, full, skip, full, ...). Prints every run's
# time, the medians and the load average before and after.
#   tests/bench/rt_skip.sh build/nimbus SCENE [WIDTHxHEIGHT] [ROUNDS] [--set ...]
# Time: what `nimbus rt` prints per frame (parameter and buffer upload, dispatch, wait and
# read-back); the context, the shader compile and the CPU's grids (the majorant grid, a
# multiple-scattering grid, baked noise) are apart. The two images are the same bit for bit
# (tests/test_rt_march.cpp, RtSkip.*).
set -euo pipefail
nimbus=${1:?usage: rt_skip.sh path/to/nimbus SCENE [WxH] [rounds] [--set k=v ...]}
scenePath=${2:?usage: rt_skip.sh path/to/nimbus SCENE [WxH] [rounds] [--set k=v ...]}
size=${3:-160x90}
rounds=${4:-3}
shift $(( $# < 4 ? $# : 4 ))
. "$(dirname "$0")/rt_bench_common.sh"
rt_bench_init "$size"
sets=(--set "camera.width=$w" --set "camera.height=$h" --set "output.preview=\"\"" "$@")
skip=()
full=()
frameTime() {
    "$nimbus" rt "$scenePath" --frames 1 -o "$tmp/$1.####.exr" "${sets[@]}" 2>/dev/null \
        --set "render.skip_empty=$2" |
        rt_gpu_seconds
}
# one untimed run of each first: llvmpipe compiles a new shader on its first dispatch (inside
# the frame's time) and keeps it in Mesa's on-disk shader cache for the later processes
frameTime skip true >/dev/null
frameTime full false >/dev/null
echo "load before: $(uptime)"
for r in $(seq 1 "$rounds"); do
    s=$(frameTime skip true)
    f=$(frameTime full false)
    echo "round $r: skip $s s, full $f s"
    skip+=("$s")
    full+=("$f")
done
echo "load after: $(uptime)"
rt_medians skip "${skip[*]}" full "${full[*]}"
