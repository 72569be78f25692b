#!/bin/bash
# rt_vs_cpu.sh: frame time of the GLSL march pass (`nimbus rt`) against the CPU `march`
# (`nimbus render`) at the same settings, runs interleaved (gpu, cpu, gpu, cpu, ...), on the
# default scene with multiple scattering off and the noise evaluated directly (the subset the
# GPU renders; docs/realtime.md). Prints every run's time and the median ratio.
#   tests/bench/rt_vs_cpu.sh build/nimbus [WIDTHxHEIGHT] [ROUNDS] [FRAME] [extra --set ...]
# GPU time: upload, dispatch and read-back (the shader compile and the context are reported
# apart); CPU time: the render of the frame as `--progress json` reports it (its plan, majorant
# grid and integration), all cores.
set -euo pipefail
nimbus=${1:?usage: rt_vs_cpu.sh path/to/nimbus [WxH] [rounds] [frame] [--set k=v ...]}
size=${2:-160x90}
rounds=${3:-3}
frame=${4:-1}
shift $(( $# < 4 ? $# : 4 ))
. "$(dirname "$0")/rt_bench_common.sh"
rt_bench_init "$size"
sets=(--set "camera.width=$w" --set "camera.height=$h" --set 'render.multiple_scattering="none"'
      --set 'field.evaluation="direct"' --set "output.preview=\"\"" "$@")
gpu=()
cpu=()
for r in $(seq 1 "$rounds"); do
    g=$("$nimbus" rt "$scene" --frames "$frame" -o "$tmp/g.####.exr" "${sets[@]}" |
        rt_gpu_seconds)
    c=$("$nimbus" render "$scene" --frames "$frame" -o "$tmp/c.####.exr" --progress json \
        "${sets[@]}" 2>&1 >/dev/null | sed -n 's/.*"event": *"frame_done".*"seconds": *\([0-9.e+-]*\).*/\1/p')
    echo "round $r: gpu $g s, cpu $c s"
    gpu+=("$g")
    cpu+=("$c")
done
rt_medians gpu "${gpu[*]}" cpu "${cpu[*]}"
