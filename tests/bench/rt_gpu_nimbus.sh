#!/bin/bash
# rt_gpu_nimbus.sh: frame times of `nimbus rt` itself (the whole command: scene, plan, the CPU's
# grids, upload, dispatch, read-back, the EXR and its preview written) for the default scene
# and smoke1 at 1280x720 and 1920x1080, one pass and 4 accumulated passes, with shadow marches
# (as the scenes ship) and with the light-attenuation volume; the default scene also with its
# noise in Olajos' RGBA8 3D textures (field.evaluation = "rgba"). Run it on the machine with
# the GPU (tests/bench/rt_gpu_pack.sh packs nimbus for one without Nimbus' dependencies); on
# llvmpipe pass small SIZES to try it.
#   tests/bench/rt_gpu_nimbus.sh path/to/nimbus OUT_DIR [FRAMES] [SIZES...]
# Each run renders frames 1..FRAMES of the scene (the default scene's clouds drift between
# them); frame 1 compiles the shader and is left out of the medians. One row per run, medians
# over frames 2..FRAMES (min-max in brackets): the time `nimbus rt` prints per frame on the GPU
# (upload, work buffers, dispatches, wait, read-back of 12 floats a pixel); the march alone on
# the GPU's clock (GL_TIMESTAMP queries before and after each dispatch, summed over the
# passes); the frame's three parts (the data uploaded / the work buffers zeroed, the dispatches
# and the wait / the read-back); the CPU's time for the frame's grids (multiple scattering,
# light volume); and the command's wall time per frame (its whole wall time less the context
# and the compile, over FRAMES: the scene, the noise bake, the grids, the GPU and the EXR
# written). The smoke1 scene reads ../shared/data/vdb/openvdb_smoke1.vdb beside the repository.
# Also writes OUT_DIR/rt_cumulus.0001.exr, rt_smoke1.0001.exr (480x270, frame 1, as the scenes
# ship), rt_cumulus_rgba.0001.exr (the same with "rgba") and goal_<baked|rgba>_n<4|16>.0001.exr
# (the goal configuration below) for tests/bench/rt_gpu_accuracy.py.
set -euo pipefail
nimbus=${1:?usage: rt_gpu_nimbus.sh path/to/nimbus OUT_DIR [FRAMES] [SIZES...]}
out=${2:?usage: rt_gpu_nimbus.sh path/to/nimbus OUT_DIR [FRAMES] [SIZES...]}
frames=${3:-6}
shift $(($# < 3 ? $# : 3))
sizes=("$@")
[ ${#sizes[@]} -gt 0 ] || sizes=(1280x720 1920x1080)
here=$(cd "$(dirname "$0")/../.." && pwd)
mkdir -p "$out"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# frame 1 of both scenes as they ship at 480x270, for rt_gpu_accuracy.py (against the CPU)
for s in cumulus smoke1; do
    "$nimbus" rt "$here/examples/scenes/$s.toml" --frames 1 -q -o "$out/rt_$s.####.exr" \
        --set camera.width=480 --set camera.height=270 --set 'output.preview=""'
done
# and the default scene with its noise in Olajos' RGBA8 textures (field.evaluation = "rgba")
"$nimbus" rt "$here/examples/scenes/cumulus.toml" --frames 1 -q -o "$out/rt_cumulus_rgba.####.exr" \
    --set camera.width=480 --set camera.height=270 --set 'output.preview=""' \
    --set 'field.evaluation="rgba"'
# the issue's goal configuration (the light volume at step x1.5, the volume's voxel kept at the
# x1 plan's, one sample per pixel), 4 and 16 passes, float tiles and "rgba", for
# rt_gpu_accuracy.py's goal rows
goal=(--set render.step=0.06 --set render.step_growth=0.006 --set render.shadow_step=0.075
      --set 'render.shadow="volume"' --set render.light_volume_cell=0.234375
      --set render.pixel_samples=1)
for mode in baked rgba; do
    for acc in 4 16; do
        "$nimbus" rt "$here/examples/scenes/cumulus.toml" --frames 1 -q --accumulate "$acc" \
            -o "$out/goal_${mode}_n$acc.####.exr" --set camera.width=480 --set camera.height=270 \
            --set 'output.preview=""' --set "field.evaluation=\"$mode\"" "${goal[@]}"
    done
done
echo "| scene | size | passes | frame on the GPU, ms: median [min-max] | the march on the GPU's clock, ms | upload / dispatches and wait / read-back, ms | CPU grids per frame, ms | wall per frame, ms |"
echo "| --- | --- | --- | --- | --- | --- | --- | --- |"
run() { # LABEL SCENE WxH ACCUMULATE [--set k=v ...]
    local label=$1 scene=$2 size=$3 acc=$4 text t0 t1
    shift 4
    t0=$(date +%s.%N)
    if ! text=$("$nimbus" rt "$here/examples/scenes/$scene" --frames "1-$frames" --accumulate "$acc" \
        -o "$work/f.####.exr" --set "camera.width=${size%x*}" --set "camera.height=${size#*x}" \
        --set 'output.preview=""' "$@" 2>&1); then
        echo "| $label | $size | $acc | FAILED: $(echo "$text" | tail -3 | tr '\n' ' ') | | | |"
        return
    fi
    t1=$(date +%s.%N)
    echo "$text" >>"$out/rt_runs.log"
    python3 - "$label" "$size" "$acc" "$t0" "$t1" "$text" <<'PY'
import re, statistics, sys
label, size, acc, t0, t1, text = sys.argv[1:7]
frames = re.findall(r"^frame (\d+): \d+x\d+, ([0-9.]+) s on the GPU \(the march ([0-9.]+) ms on its "
                    r"clock; upload ([0-9.]+) s, dispatches and wait ([0-9.]+) s, read-back ([0-9.]+) s",
                    text, re.M)
grids = {int(f): float(s) for f, s in re.findall(r"^frame (\d+): .* computed on the CPU in ([0-9.]+) s", text, re.M)}
context = float(re.search(r"context in ([0-9.]+) s", text).group(1))
compile_s = float(re.search(r"shader compiled in ([0-9.]+) s", text).group(1))
late = [[float(v) for v in r[1:]] for r in frames if int(r[0]) > 1] or \
       [[float(v) for v in r[1:]] for r in frames]
def col(k, scale):
    return [scale * r[k] for r in late]
def med(xs):
    return f"{statistics.median(xs):.2f} [{min(xs):.2f}-{max(xs):.2f}]"
parts = " / ".join(f"{statistics.median(col(k, 1e3)):.1f}" for k in (2, 3, 4))
wall = (float(t1) - float(t0) - context - compile_s) * 1e3 / len(frames)
g = [1e3 * v for f, v in grids.items() if f > 1]
print(f"| {label} | {size} | {acc} | {med(col(0, 1e3))} | {med(col(1, 1.0))} | {parts} | "
      f"{f'{statistics.median(g):.1f}' if g else '-'} | {wall:.0f} |")
PY
}
volume=(--set 'render.shadow="volume"')
rgba=(--set 'field.evaluation="rgba"')
for size in "${sizes[@]}"; do
    for acc in 1 4; do
        run "default scene as it ships" cumulus.toml "$size" "$acc"
        run "default scene, light volume" cumulus.toml "$size" "$acc" "${volume[@]}"
        run "default scene, rgba noise" cumulus.toml "$size" "$acc" "${rgba[@]}"
        run "default scene, light volume, rgba noise" cumulus.toml "$size" "$acc" "${volume[@]}" "${rgba[@]}"
        run "smoke1 as it ships" smoke1.toml "$size" "$acc"
        run "smoke1, light volume" smoke1.toml "$size" "$acc" "${volume[@]}"
    done
done
for mode in baked rgba; do
    run "goal: light volume, step x1.5, $mode" cumulus.toml "${sizes[-1]}" 4 "${goal[@]}" \
        --set "field.evaluation=\"$mode\""
done
