#!/bin/bash
# Cron wrapper: advance a sweep a little at every tick, safely.
#
# crontab -e, then (see workflows/crontab.example):
#   */30 * * * * /path/to/workflows/cron_simulate.sh /path/to/configs/phase.yaml >> /path/to/phase.cron.log 2>&1
#
# - `flock -n -E 75` on <config>.cron.lock: if the previous tick is still running this
#   tick logs "skipped" and exits at once with status 0 (no pile-up of processes, no
#   cron mail).
# - Even without flock, two overlapping `fcsweep simulate` never compute the same run:
#   per-run locks make the second one skip runs held by the first.
# - Each tick skips finished runs and resumes interrupted ones from their checkpoints.
# Environment: FCSWEEP (command, default `fcsweep`), FCSWEEP_WORKERS (default 1).
set -euo pipefail
CONFIG=${1:?usage: cron_simulate.sh CONFIG [fcsweep simulate options]}
shift
FCSWEEP=${FCSWEEP:-fcsweep}
LOCK="${CONFIG}.cron.lock"
echo "[$(date -Is)] cron tick: ${CONFIG}"
set +e
flock -n -E 75 "${LOCK}" ${FCSWEEP} simulate "${CONFIG}" --workers "${FCSWEEP_WORKERS:-1}" --log-every 600 "$@"
rc=$?
if [ ${rc} -eq 75 ]; then
    echo "[$(date -Is)] cron tick skipped: the previous tick still holds ${LOCK}"
    exit 0
fi
echo "[$(date -Is)] cron tick finished with status ${rc}"
exit ${rc}
