"""How many processes and threads a local pool may use (re-exported from
:mod:`fcsweep.io.machine`, which lives below both the sweep runner and the analysis
pipeline so that neither imports the other for it)."""

from fcsweep.io.machine import available_cores, cgroup_cpu_quota, worker_layout

__all__ = ["available_cores", "cgroup_cpu_quota", "worker_layout"]
