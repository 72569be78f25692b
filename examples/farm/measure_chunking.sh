#!/usr/bin/env bash
# Measures what chunking saves: FRAMES frames of a scene rendered as farm tasks of PER frames
# each, one task after another on this machine (one farm slot), each task a fresh process run
# through examples/farm/nimbus_slurm.sh as Slurm would run it (SLURM_ARRAY_TASK_ID set).
#   examples/farm/measure_chunking.sh NIMBUS SCENE FIRST LAST PER [nimbus render options...]
# Prints per task: its frames, time to first pixel (process start to the first frame's
# "frame 1/N 0%" progress line: scene load, VDB read, the frame's setup), its wall time; then
# the totals. "later setup s" is, for the 2nd and later frames of a task, the mean time from
# the previous frame's result line to the frame's first progress line (its grids bound). Outputs go to a temp folder that is removed.
set -euo pipefail
[ $# -ge 5 ] || { echo "usage: $0 NIMBUS SCENE FIRST LAST PER [options...]" >&2; exit 2; }
nimbus=$(readlink -f "$1") scene=$2 first=$3 last=$4 per=$5
shift 5
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
tasks=$(((last - first) / per + 1))
calc() { awk "BEGIN { printf \"%.2f\", $* }"; }
total0=$EPOCHREALTIME
sum_ttfp=0
printf '%-6s %-8s %14s %14s %10s\n' task frames "first pixel s" "later setup s" "wall s"
for ((i = 0; i < tasks; i++)); do
  t0=$EPOCHREALTIME
  SLURM_ARRAY_TASK_ID=$i NIMBUS="$nimbus" bash "$here/nimbus_slurm.sh" "$scene" \
    "$out/f.####.exr" "$first" "$last" "$per" "$@" 2>&1 |
    while IFS= read -r line; do printf '%s %s\n' "$EPOCHREALTIME" "$line"; done >"$out/log.$i"
  rc=${PIPESTATUS[0]}
  t1=$EPOCHREALTIME
  [ "$rc" -eq 0 ] || { echo "task $i failed (exit $rc):" >&2; tail -n 5 "$out/log.$i" >&2; exit "$rc"; }
  ttfp=$(awk -v t0="$t0" '/ frame 1\/[0-9]+ 0% /{printf "%.2f", $1 - t0; exit}' "$out/log.$i")
  later=$(awk '/ -> /{prev = $1} match($0, / frame [0-9]+\//) {
      k = substr($0, RSTART + 7, RLENGTH - 8) + 0
      if (k >= 2 && !(k in seen)) { seen[k] = 1; sum += $1 - prev; n++ } }
    END { if (n) printf "%.3f", sum / n; else printf "-" }' "$out/log.$i")
  frames=$(grep -oE 'frames [0-9-]+' "$out/log.$i" | head -n 1 | cut -d' ' -f2)
  printf '%-6s %-8s %14s %14s %10.2f\n' "$i" "$frames" "$ttfp" "$later" "$(calc "$t1 - $t0")"
  sum_ttfp=$(calc "$sum_ttfp + $ttfp")
done
printf 'total: %d tasks of %d frames, wall %.2f s, summed time to first pixel %.2f s\n' \
  "$tasks" "$per" "$(calc "$EPOCHREALTIME - $total0")" "$sum_ttfp"
