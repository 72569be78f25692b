#!/usr/bin/env bash
# One task of a Slurm array job that renders a frame range in chunks: task i renders frames
# FIRST + i*PER .. min(FIRST + i*PER + PER - 1, LAST), in one nimbus process, so the scene (and a
# VDB field's file) is loaded once per chunk, not once per frame. Submit with
#   sbatch --array=0-$(( (LAST - FIRST) / PER )) examples/farm/nimbus_slurm.sh \
#          SCENE OUTPUT FIRST LAST PER [more nimbus render options...]
# or let examples/farm/submit.sh work out --array. OUTPUT is a pattern such as
# shots/a/f.####.exr (docs/farm.md).
#
# Requeue-friendly: --resume makes a requeued (or retried) task render only the frames of its
# chunk that are missing or not a complete EXR of the scene's resolution; temp files that a
# killed run left are removed by the next run. The script execs nimbus, so Slurm's signals
# (scancel, preemption, time limit: SIGTERM) reach it directly and its exit code is the task's:
#   0 ok, 1 internal error, 2 bad input, 3 I/O error, 4 out of memory, 130 interrupted.
#
# Environment: NIMBUS (the binary, default: nimbus on PATH), NIMBUS_THREADS (worker threads,
# default: the CPUs Slurm gave the task, SLURM_CPUS_PER_TASK, else 0 = all cores).
#SBATCH --job-name=nimbus
#SBATCH --requeue
#SBATCH --open-mode=append
#SBATCH --output=nimbus-%A_%a.log
set -euo pipefail

if [ $# -lt 5 ]; then
  echo "usage: $0 SCENE OUTPUT FIRST LAST PER [nimbus render options...]" >&2
  exit 2
fi
scene=$1 output=$2 first=$3 last=$4 per=$5
shift 5
for v in "$first" "$last" "$per"; do
  if ! [[ $v =~ ^-?[0-9]+$ ]]; then
    echo "nimbus_slurm: FIRST, LAST and PER must be integers, got '$v'" >&2
    exit 2
  fi
done
if [ "$per" -lt 1 ] || [ "$last" -lt "$first" ]; then
  echo "nimbus_slurm: need PER >= 1 and LAST >= FIRST (got PER=$per, $first-$last)" >&2
  exit 2
fi
task=${SLURM_ARRAY_TASK_ID:-0}
start=$((first + task * per))
end=$((start + per - 1))
if [ "$end" -gt "$last" ]; then end=$last; fi
if [ "$start" -gt "$last" ]; then
  echo "nimbus_slurm: task $task is past the range $first-$last (PER=$per): nothing to do" >&2
  exit 0
fi
threads=${NIMBUS_THREADS:-${SLURM_CPUS_PER_TASK:-0}}
echo "nimbus_slurm: job ${SLURM_JOB_ID:-none} task $task (restart ${SLURM_RESTART_COUNT:-0})" \
  "on $(hostname): frames $start-$end, $(date -u +%FT%T.%3NZ)" >&2
exec "${NIMBUS:-nimbus}" render "$scene" --frames "$start-$end" --resume --progress plain \
  --threads "$threads" -o "$output" "$@"
