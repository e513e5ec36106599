"""What this machine offers a local pool: cores (affinity, cgroup quota) and the
process x thread layout that never oversubscribes them."""

from __future__ import annotations

import math
import os


def available_cores() -> int:
    """Cores this process may run on: its CPU affinity (the CPU count elsewhere), capped
    by a cgroup v2 CPU quota (containers started with ``--cpus``, batch-job limits)."""
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - non-Linux
        cores = os.cpu_count() or 1
    quota = cgroup_cpu_quota()
    return max(1, min(cores, quota)) if quota else cores


def cgroup_cpu_quota(path: str = "/sys/fs/cgroup/cpu.max") -> int | None:
    """CPUs allowed by the cgroup v2 file ``cpu.max`` ("quota period", rounded up), or
    None if there is no quota ("max") or no such file."""
    try:
        with open(path) as fh:
            quota, period = fh.read().split()[:2]
    except (OSError, ValueError):
        return None
    if quota == "max":
        return None
    try:
        return max(1, math.ceil(int(quota) / int(period)))
    except (ValueError, ZeroDivisionError):
        return None


def worker_layout(workers: int) -> tuple[int, int]:
    """(processes, threads per process) for ``workers`` jobs at once on this machine:
    never more processes than cores, and processes x threads <= cores."""
    cores = available_cores()
    processes = max(1, min(int(workers), cores))
    return processes, max(1, cores // processes)
