#!/bin/bash
# rt_gpu_run.sh: GPU frame times of the exports written by rt_gpu_exports.sh, on the machine
# with the GPU (nimbus_headless: EGL, no window, GL timestamp queries; docs/realtime.md, "On a
# machine with a GPU"). Prints one table row per run; the 480x270 accuracy set's images go to
# OUT_DIR as PFM for rt_gpu_accuracy.sh.
#   [ONLY=REGEX] tests/bench/rt_gpu_run.sh path/to/nimbus_headless EXPORTS_DIR OUT_DIR [FRAMES]
# Each run: 5 untimed frames, then FRAMES (default 30) timed; the row gives the median GPU time
# of a frame (every accumulation pass of it) and of one accumulation pass (what an engine that
# spreads the passes over displayed frames spends per frame), min-max in brackets, and the
# median wall time (dispatch to glFinish).
set -euo pipefail
headless=${1:?usage: rt_gpu_run.sh path/to/nimbus_headless EXPORTS_DIR OUT_DIR [FRAMES]}
dir=${2:?usage: rt_gpu_run.sh path/to/nimbus_headless EXPORTS_DIR OUT_DIR [FRAMES]}
out=${3:?usage: rt_gpu_run.sh path/to/nimbus_headless EXPORTS_DIR OUT_DIR [FRAMES]}
frames=${4:-30}
mkdir -p "$out"
# the data files stored once (rt_gpu_exports.sh): linked back into each export
while read -r file sum; do
    [ -e "$dir/$file" ] || ln "$dir/store/$sum" "$dir/$file"
done <"$dir/links.txt"

# the GL renderer and platform, from the first export there is (ONLY may have left some out)
first=$(find "$dir" -mindepth 2 -maxdepth 2 -name params.json | sort | head -1)
"$headless" "$(dirname "$first")" --frames 1 --warmup 0 | head -1
echo
echo "| export | accumulate | frame GPU ms median [min-max] | pass GPU ms median [min-max] | frame wall ms median |"
echo "| --- | --- | --- | --- | --- |"
run() { # EXPORT ACCUMULATE [--pfm FILE]
    local name=$1 acc=$2 text
    shift 2
    # ONLY=REGEX: only the exports whose name matches
    [[ -z ${ONLY:-} || $name =~ $ONLY ]] || return 0
    if ! text=$("$headless" "$dir/$name" --frames "$frames" --warmup 5 --accumulate "$acc" "$@" 2>&1); then
        echo "| $name | $acc | FAILED: $(echo "$text" | tail -3 | tr '\n' ' ') | | |"
        return
    fi
    echo "$text" >>"$out/runs.log"
    python3 - "$name" "$acc" "$text" <<'PY'
import re, sys
name, acc, text = sys.argv[1:4]
def row(key):
    m = re.search(key + r" ms: median ([0-9.]+), min ([0-9.]+), max ([0-9.]+)", text)
    return m.groups()
f, p, w = row("frame GPU"), row("pass GPU"), row("frame wall")
print(f"| {name} | {acc} | {float(f[0]):.3f} [{float(f[1]):.3f}-{float(f[2]):.3f}] | "
      f"{float(p[0]):.3f} [{float(p[1]):.3f}-{float(p[2]):.3f}] | {float(w[0]):.3f} |")
PY
}
for size in 1280x720 1920x1080; do
    for scene in cumulus cumulus_nofwd cumulus_noms smoke1 smoke1_nofwd; do
        run "${scene}_${size}" 1
        run "${scene}_${size}" 4
    done
done
run cumulus_noms_direct_1920x1080 1
run cumulus_noms_noskip_1920x1080 1
for m in 1 2 4; do
    run "cumulus_noms_direct_m${m}_1920x1080" 1
    run "cumulus_noms_direct_m${m}_1920x1080" 8
done
# render.shadow = "volume" (the light-attenuation volume)
for size in 1280x720 1920x1080; do
    run "cumulus_volume_${size}" 1
    run "cumulus_volume_${size}" 4
    run "smoke1_volume_${size}" 1
done
for m in 1.5 1.75 2 4; do
    run "cumulus_m${m}_1920x1080" 1
    run "cumulus_volume_m${m}_1920x1080" 1
    run "cumulus_volume_m${m}_1920x1080" 8
done
run cumulus_volume_nofwd_m1.5_1920x1080 1
# the SDF cloud and the dragon
for size in 1280x720 1920x1080; do
    run "sdf_cloud_${size}" 1
    run "dragon_${size}" 1
    run "dragon_volume_${size}" 1
done
run sdf_cloud_march_1920x1080 1
# the accuracy set: few frames, the last frame's image kept
for m in 1 2 4; do
    for n in 1 4 16; do
        frames=2 run "acc_m${m}_480x270" "$n" --pfm "$out/acc_m${m}_n${n}.pfm"
    done
done
for m in 1 1.5 1.75 2 4; do
    for n in 1 4 16; do
        frames=2 run "acc_volume_m${m}_480x270" "$n" --pfm "$out/acc_volume_m${m}_n${n}.pfm"
    done
done
frames=2 run cumulus_480x270 1 --pfm "$out/cumulus_480x270.pfm"
frames=2 run smoke1_480x270 1 --pfm "$out/smoke1_480x270.pfm"
frames=2 run cumulus_volume_480x270 1 --pfm "$out/cumulus_volume_480x270.pfm"
frames=2 run smoke1_volume_480x270 1 --pfm "$out/smoke1_volume_480x270.pfm"
