#!/bin/bash
# rt_accumulate.sh: temporal accumulation of the GLSL march pass (`nimbus rt --accumulate N`)
# against a converged CPU `march` reference at a fine step: the error (PSNR over RGB with the
# reference's largest RGB value as the peak, and the relative RMSE sqrt(sum d^2 / sum ref^2)) and
# the llvmpipe time of each (step multiplier m, passes N). The table in docs/realtime.md
# ("Temporal accumulation") comes from this script.
#   tests/bench/rt_accumulate.sh build/nimbus [WIDTHxHEIGHT] ["m ..."] ["N ..."] [REF_M] [REF_SEEDS]
# The default scene, frame 1, multiple scattering off, the noise evaluated directly (the subset
# the GPU renders). A step multiplier m scales the rows of the step schedule that scale with the
# step (render.step, render.step_growth, render.shadow_step: io::scaleSteps) of the scene's 0.04,
# 0.004 and 0.05. The reference: `nimbus render` at m = REF_M (default 0.25), the mean of
# REF_SEEDS (default 4) renders with render.seed 1..REF_SEEDS (the seed keys only the jitter), one
# ray through each pixel's centre as the GPU's (pixel_samples 1). Errors are in the EXR's space
# (ACEScg, output.color_space). GPU time: what `nimbus rt` prints (upload, every dispatch, wait,
# read-back), wall-clock; CPU time: user + system seconds of the whole `nimbus rt` process
# (llvmpipe runs the shader on the CPU's threads; this also holds the scene load, the context and
# the compile, about 0.3 s), less sensitive than the wall clock to other load on the machine.
set -euo pipefail
nimbus=${1:?usage: rt_accumulate.sh path/to/nimbus [WxH] ["m ..."] ["N ..."] [ref_m] [ref_seeds]}
size=${2:-160x90}
mults=${3:-1 2 4}
counts=${4:-1 2 4 8 16}
refm=${5:-0.25}
refseeds=${6:-4}
. "$(dirname "$0")/rt_bench_common.sh"
rt_bench_init "$size"
base=(--set "camera.width=$w" --set "camera.height=$h" --set 'render.multiple_scattering="none"'
      --set 'field.evaluation="direct"' --set 'output.preview=""' --set 'render.pixel_samples=1')
steps() { # the step schedule scaled by $1
    python3 -c "m=float('$1'); print(f'render.step={0.04*m:.9g} render.step_growth={0.004*m:.9g} render.shadow_step={0.05*m:.9g}')"
}
sets_for() {
    local out=()
    for kv in $(steps "$1"); do out+=(--set "$kv"); done
    echo "${out[@]}"
}
dump() { oiiotool --dumpdata "$1" | sed -n 's/^ *Pixel ([0-9]*, [0-9]*): //p' | cut -d' ' -f1-3 > "$2"; }

echo "reference: nimbus render at m = $refm, mean of $refseeds seeds, ${w}x${h}" >&2
refs=()
for s in $(seq 1 "$refseeds"); do
    t0=$(date +%s.%N)
    # shellcheck disable=SC2046
    "$nimbus" render "$scene" --frames 1 -o "$tmp/ref$s.####.exr" -q "${base[@]}" \
        $(sets_for "$refm") --set "render.seed=$s" 2>/dev/null
    t1=$(date +%s.%N)
    echo "  seed $s: $(python3 -c "print(f'{$t1 - $t0:.2f}')") s (process)" >&2
    dump "$tmp/ref$s.0001.exr" "$tmp/ref$s.txt"
    refs+=("$tmp/ref$s.txt")
done

echo "| m | N | PSNR (dB) | relative RMSE | llvmpipe time (s) | process CPU time (s) |"
echo "| --- | --- | --- | --- | --- | --- |"
for m in $mults; do
    for n in $counts; do
        # shellcheck disable=SC2046
        line=$(/usr/bin/time -f '%U %S' -o "$tmp/time" "$nimbus" rt "$scene" --frames 1 -o "$tmp/g.####.exr" "${base[@]}" \
            $(sets_for "$m") --accumulate "$n" 2>/dev/null | grep '^frame 1:')
        t=$(echo "$line" | rt_gpu_seconds)
        cpu=$(awk '{print $1 + $2}' "$tmp/time")
        dump "$tmp/g.0001.exr" "$tmp/g.txt"
        python3 - "$m" "$n" "$t" "$cpu" "$tmp/g.txt" "${refs[@]}" <<'PY'
import math, sys
m, n, t, cpu, test = sys.argv[1], sys.argv[2], float(sys.argv[3]), float(sys.argv[4]), sys.argv[5]
def load(p):
    return [float(v) for line in open(p) for v in line.split()]
refs = [load(p) for p in sys.argv[6:]]
ref = [sum(v) / len(v) for v in zip(*refs)]
g = load(test)
se = sum((a - b) ** 2 for a, b in zip(g, ref))
psnr = 10 * math.log10(max(ref) ** 2 / (se / len(ref)))
rel = math.sqrt(se / sum(b * b for b in ref))
print(f"| {m} | {n} | {psnr:.2f} | {rel:.4f} | {t:.3f} | {cpu:.2f} |")
PY
    done
done
# the reference's own noise: the mean of the first half of its seeds against the second half
if [ "$refseeds" -ge 2 ]; then
    python3 - "${refs[@]}" <<'PY'
import math, sys
imgs = [[float(v) for line in open(p) for v in line.split()] for p in sys.argv[1:]]
k = len(imgs) // 2
a = [sum(v) / k for v in zip(*imgs[:k])]
b = [sum(v) / (len(imgs) - k) for v in zip(*imgs[k:])]
se = sum((x - y) ** 2 for x, y in zip(a, b))
print(f"reference halves ({k} vs {len(imgs) - k} seeds): relative RMSE {math.sqrt(se / sum(y * y for y in b)):.4f}"
      f" (the full mean's own noise is about half of that)")
PY
fi
