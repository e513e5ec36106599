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
# 2 invalid config or index, 143 stopped by SIGTERM after checkpointing.
#
# Time limits: `--signal=B:TERM@60` has SLURM send SIGTERM to this batch shell 60 s
# before the limit; the shell logs it and passes it on to fcsweep, which writes a
# checkpoint at the current step, marks the run interrupted and exits 143.  With
# --requeue the task is put back in the queue (e.g. after preemption or a node failure)
# and continues from that checkpoint; --open-mode=append keeps the log of every attempt.
#
#SBATCH --job-name=fcsweep
#SBATCH --output=fcsweep-%A_%a.log
#SBATCH --time=24:00:00
#SBATCH --ntasks=1
#SBATCH --cpus-per-task=1
#SBATCH --mem=2G
#SBATCH --requeue
#SBATCH --open-mode=append
#SBATCH --signal=B:TERM@60

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

echo "fcsweep array task ${SLURM_ARRAY_TASK_ID} (attempt ${SLURM_RESTART_COUNT:-0}) on $(hostname) at $(date -Is): ${CONFIG}"
# fcsweep runs in the background so that this shell can log the signal and forward it
# (bash runs a trap only between commands, and `wait` returns as soon as a signal comes).
child=
forward() {
    echo "[$(date -Is)] received SIG$1 (time limit, scancel or preemption): checkpointing run ${SLURM_ARRAY_TASK_ID}"
    [ -n "${child}" ] && kill -s "$1" "${child}" 2>/dev/null || true
}
trap 'forward TERM' TERM
trap 'forward USR1' USR1
trap 'forward INT' INT
${FCSWEEP} simulate "${CONFIG}" --task-index "${SLURM_ARRAY_TASK_ID}" --log-every 300 "$@" &
child=$!
set +e
while :; do
    wait "${child}"
    rc=$?
    kill -0 "${child}" 2>/dev/null || break   # wait was cut short by a signal: wait again
done
echo "[$(date -Is)] fcsweep exited with status ${rc}"
exit ${rc}
