#!/usr/bin/env bash
# A Slurm array job that renders a frame range of a Nimbus scene in chunks: array task i renders
# frames FIRST + i*CHUNK .. FIRST + (i+1)*CHUNK - 1 (at most LAST), so each task loads the scene
# and its VDB grids once for CHUNK frames. Submit it with as many array tasks as there are chunks:
#
#   first=1 last=96 chunk=8
#   sbatch --array=0-$(( (last - first) / chunk )) examples/farm/slurm_render.sh \
#       shot.toml $first $last $chunk -o /farm/out/shot.####.exr
#
# Arguments: SCENE FIRST LAST CHUNK [more nimbus render options...]. The nimbus binary is
# $NIMBUS if set, else `nimbus` on PATH. Every task runs with --resume, so a requeued or retried
# task renders only the frames of its chunk that have no valid output (a frame from an edited
# scene is rendered again: docs/farm_cli.md), and temp files that a killed run left are removed.
# Retries are bit-identical: every random number derives from the pixel, frame and render.seed.
#
# Exit status is nimbus's (docs/farm.md): 0 done, 2 bad input (do not retry), 3 I/O error
# (retry elsewhere), 4 out of memory (retry on a bigger node), 130 interrupted (requeue), 1 an
# internal error (report it). docs/farm.md has the same job for OpenCue and Deadline/OpenJD.
#SBATCH --job-name=nimbus
#SBATCH --requeue
#SBATCH --open-mode=append
#SBATCH --cpus-per-task=2
set -uo pipefail

if [ $# -lt 4 ]; then
    echo "usage: sbatch --array=0-N slurm_render.sh SCENE FIRST LAST CHUNK [nimbus render options]" >&2
    exit 2
fi
scene="$1" first="$2" last="$3" chunk="$4"
shift 4
for v in "$first" "$last" "$chunk"; do
    case "$v" in
    '' | *[!0-9-]*)
        echo "slurm_render.sh: FIRST, LAST and CHUNK must be integers, found '$v'" >&2
        exit 2
        ;;
    esac
done
if [ "$chunk" -lt 1 ] || [ "$last" -lt "$first" ]; then
    echo "slurm_render.sh: need CHUNK >= 1 and LAST >= FIRST (found $first..$last by $chunk)" >&2
    exit 2
fi
task="${SLURM_ARRAY_TASK_ID:-0}"
start=$((first + task * chunk))
end=$((start + chunk - 1))
[ "$end" -gt "$last" ] && end="$last"
if [ "$start" -gt "$last" ]; then
    echo "slurm_render.sh: array task $task starts at frame $start, past LAST $last: nothing to do"
    exit 0
fi
nimbus="${NIMBUS:-nimbus}"
echo "slurm_render.sh: job ${SLURM_JOB_ID:-local} task $task (restart ${SLURM_RESTART_COUNT:-0}) on $(hostname): frames $start-$end"
# exec: Slurm's SIGTERM (scancel, time limit, preemption) reaches nimbus itself, which stops
# within a second, removes its partial frame and exits 130.
exec "$nimbus" render "$scene" --frames "$start-$end" --resume --progress plain "$@"
