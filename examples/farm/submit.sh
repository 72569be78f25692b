#!/usr/bin/env bash
# Submits a chunked Slurm array job of examples/farm/nimbus_slurm.sh:
#   examples/farm/submit.sh SCENE OUTPUT FIRST LAST PER [nimbus render options...]
# Extra sbatch options go in SBATCH_OPTS (e.g. SBATCH_OPTS="--partition=render --cpus-per-task=8
# --output=logs/%A_%a.log"). Prints sbatch's output (the job id).
set -euo pipefail
if [ $# -lt 5 ]; then
  echo "usage: $0 SCENE OUTPUT FIRST LAST PER [nimbus render options...]" >&2
  exit 2
fi
first=$3 last=$4 per=$5
tasks=$(((last - first) / per + 1))
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
# shellcheck disable=SC2086
exec sbatch --array=0-$((tasks - 1)) ${SBATCH_OPTS:-} "$here/nimbus_slurm.sh" "$@"
