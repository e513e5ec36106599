"""How many processes and threads a local pool may use: never more than the cores."""

from __future__ import annotations

import os


def available_cores() -> int:
    """Cores this process may run on (its CPU affinity; the CPU count elsewhere)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - non-Linux
        return os.cpu_count() or 1


def worker_layout(workers: int) -> tuple[int, int]:
    """(processes, threads per process) for ``workers`` jobs at once on this machine:
    never more processes than cores, and processes x threads <= cores."""
    cores = available_cores()
    processes = max(1, min(int(workers), cores))
    return processes, max(1, cores // processes)
