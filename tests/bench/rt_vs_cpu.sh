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
here=$(cd "$(dirname "$0")/../.." && pwd)
scene="$here/examples/scenes/cumulus.toml"
w=${size%x*}
h=${size#*x}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
sets=(--set "camera.width=$w" --set "camera.height=$h" --set 'render.multiple_scattering="none"'
      --set 'field.evaluation="direct"' --set "output.preview=\"\"" "$@")
gpu=()
cpu=()
for r in $(seq 1 "$rounds"); do
    g=$("$nimbus" rt "$scene" --frames "$frame" -o "$tmp/g.####.exr" "${sets[@]}" |
        sed -n 's/^frame [0-9]*: [0-9x]*, \([0-9.]*\) s on the GPU.*/\1/p')
    c=$("$nimbus" render "$scene" --frames "$frame" -o "$tmp/c.####.exr" --progress json \
        "${sets[@]}" 2>&1 >/dev/null | sed -n 's/.*"event": *"frame_done".*"seconds": *\([0-9.e+-]*\).*/\1/p')
    echo "round $r: gpu $g s, cpu $c s"
    gpu+=("$g")
    cpu+=("$c")
done
python3 - "${gpu[*]}" "${cpu[*]}" <<'PY'
import statistics, sys
g = [float(x) for x in sys.argv[1].split()]
c = [float(x) for x in sys.argv[2].split()]
mg, mc = statistics.median(g), statistics.median(c)
print(f"median gpu {mg:.4f} s, cpu {mc:.4f} s, gpu/cpu {mg / mc:.2f}")
PY
