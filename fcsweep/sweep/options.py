"""The options of ``fcsweep simulate`` that travel from the command line down to each run,
as one frozen record: :class:`SweepOptions`, built once by the command and handed to
:func:`fcsweep.sweep.launch.simulate_runs`, :func:`fcsweep.sweep.launch.compute`,
:func:`fcsweep.sweep.executors.run_sweep` and :func:`fcsweep.sweep.plan.plan_runs`.
"""

from __future__ import annotations

from dataclasses import dataclass

from fcsweep.io.locks import DEFAULT_STALE_AFTER

__all__ = ["SweepOptions", "EXECUTORS", "CLUSTER_EXTRA_HINT", "dask_missing"]

#: Ways of computing the runs of a sweep.
EXECUTORS = ("serial", "process", "dask")
#: What to install for ``--executor dask`` (the ``cluster`` extra holds ``dask[distributed]``).
CLUSTER_EXTRA_HINT = 'pip install "fcsweep[cluster]"'


@dataclass(frozen=True)
class SweepOptions:
    """How ``fcsweep simulate`` computes the selected runs.

    Attributes
    ----------
    executor : {"serial", "process", "dask"}
        ``serial`` runs in this process; ``process`` a spawn-context process pool of
        ``workers`` processes; ``dask`` submits to the distributed scheduler at
        ``scheduler``.
    workers : int
        Processes of the ``process`` executor.
    scheduler : str or None
        Dask scheduler address (e.g. ``tcp://host:8786``).
    force : bool
        Recompute runs even if done (checkpoints ignored).
    retry_failed : bool
        Rerun runs that failed for a reason a relaunch does not fix; without it they are
        reported failed (``force`` implies it).
    stale_after : float
        Seconds without heartbeat after which a run lock no longer counts.
    """

    executor: str = "serial"
    workers: int = 1
    scheduler: str | None = None
    force: bool = False
    retry_failed: bool = False
    stale_after: float = DEFAULT_STALE_AFTER

    def __post_init__(self) -> None:
        if self.executor not in EXECUTORS:
            raise ValueError(f"executor {self.executor!r} is not one of {EXECUTORS}")

    @property
    def skip_failed(self) -> bool:
        """Whether runs that failed earlier (not for an I/O cause) are reported, not rerun."""
        return not (self.retry_failed or self.force)


def dask_missing() -> str | None:
    """The one line to show when ``--executor dask`` cannot work here because
    ``dask.distributed`` is not importable, else ``None``."""
    try:
        import distributed  # noqa: F401
    except ImportError as exc:
        return f"--executor dask needs dask.distributed ({exc}): {CLUSTER_EXTRA_HINT}"
    return None
