#!/bin/bash
# SLURM job array: one array task = one run of a sweep (fcsweep simulate --task-index).
#
# Submit (one task per run; `fcsweep list-runs CONFIG` shows which index is which):
#
#   sbatch --array=0-$(($(fcsweep list-runs configs/phase.yaml --count)-1)) \
#          workflows/slurm_array.sh configs/phase.yaml
#
# Limit concurrency with --array=0-35%8.  Extra arguments after CONFIG go to
# `fcsweep simulate` (e.g. --lock-timeout 3600).  Resubmitting the same array is safe:
# finished runs are skipped, interrupted ones (time limit, preemption, node failure)
# resume from their last checkpoint, and a run still held by a live task is skipped.
# Exit code: 0 done or skipped, 1 the run failed (see `fcsweep status CONFIG`),
# 2 invalid config or index.
#
#SBATCH --job-name=fcsweep
#SBATCH --output=fcsweep-%A_%a.log
#SBATCH --time=24:00:00
#SBATCH --ntasks=1
#SBATCH --cpus-per-task=1
#SBATCH --mem=2G
#SBATCH --requeue

set -euo pipefail

if [ $# -lt 1 ]; then
    echo "usage: sbatch --array=0-(N-1) $0 CONFIG [fcsweep simulate options]" >&2
    exit 2
fi
CONFIG=$1
shift
if [ -z "${SLURM_ARRAY_TASK_ID:-}" ]; then
    echo "$0: SLURM_ARRAY_TASK_ID is not set; submit with sbatch --array=..." >&2
    exit 2
fi

# One numba thread per allocated CPU.  Compiled kernels are cached (numba cache=True)
# beside the installed package, or in the user's cache directory if that is read-only;
# export NUMBA_CACHE_DIR=/some/shared/dir to choose (a node-local one recompiles per node).
export NUMBA_NUM_THREADS=${SLURM_CPUS_PER_TASK:-1}
export OMP_NUM_THREADS=1
FCSWEEP=${FCSWEEP:-fcsweep}

echo "fcsweep array task ${SLURM_ARRAY_TASK_ID} on $(hostname) at $(date -Is): ${CONFIG}"
exec ${FCSWEEP} simulate "${CONFIG}" --task-index "${SLURM_ARRAY_TASK_ID}" --log-every 300 "$@"
