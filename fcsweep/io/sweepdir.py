"""A sweep directory ``<output>/``: where its files are, and what state each run is in.

One place for what every command reads of a sweep directory:

- paths: :func:`run_path` (``<output>/runs/<run_id>``), the file names of
  :mod:`fcsweep.io.schema`;
- :func:`atomic_write` (of :mod:`fcsweep.io.atomic`): the temporary-file-and-rename write behind ``status.json``,
  ``checkpoint.npz`` and ``refinement.json`` (a reader sees the old file or the new one);
- :func:`run_state`: the state word of one run (``status.json`` read once, its lock and
  trajectory looked at once), which ``fcsweep status``, ``analyze``, ``aggregate`` and the
  sweep runner's life cycle (:mod:`fcsweep.sweep.lifecycle`) all use, so that they name
  the same state;
- :func:`refinement_points`: the grid points ``fcsweep refine`` recorded
  (:mod:`fcsweep.io.refinement`).

States (:data:`fcsweep.io.schema.STATUSES`) as a reader should show them:

========================================  ==============
files                                     state
========================================  ==============
no ``status.json``                        ``pending``
status ``done`` with ``trajectory.h5``    ``done``
status ``done``, ``trajectory.h5`` gone   ``corrupt``
any other status, live lock               ``running``
status ``running``, no live lock          ``interrupted``
otherwise                                 the status word
========================================  ==============

A done run whose trajectory is missing is ``corrupt`` (the verification of
:meth:`fcsweep.io.rundir.RunDirectory.verify` fails with "trajectory.h5 is missing") and
the next ``simulate`` recomputes it, as for any damaged trajectory.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from fcsweep.io import schema
from fcsweep.io.atomic import atomic_write, fsync_dir
from fcsweep.io.failures import WriteFailure
from fcsweep.io.locks import DEFAULT_STALE_AFTER, lock_info, lock_is_stale
from fcsweep.io.refinement import read_points
from fcsweep.io.status import read_status

__all__ = ["RUNS", "run_path", "atomic_write", "WriteFailure", "RunState", "run_state", "state_of", "refinement_points",
           "fsync_dir", "MISSING_TRAJECTORY"]

#: Sub-directory of the output directory that holds one directory per run.
RUNS = "runs"
#: Reason of a done run whose trajectory is gone (as :meth:`RunDirectory.mark_corrupt` words it).
MISSING_TRAJECTORY = "trajectory.h5 damaged: trajectory.h5 is missing"


def run_path(output, run_id: str) -> Path:
    """Directory of one run: ``<output>/runs/<run_id>``."""
    return Path(output) / RUNS / run_id


@dataclass(frozen=True)
class RunState:
    """What the files of one run say, read once.

    Attributes
    ----------
    state : str
        One of :data:`fcsweep.io.schema.STATUSES` (see the module table).
    reason : str
        Why, for people: ``status.json``'s ``reason`` or, for a derived state, its cause.
    status : dict or None
        ``status.json`` (``None`` if there is none or it is unreadable).
    lock : dict or None
        The run lock's contents while a live process holds it, else ``None``.
    has_trajectory : bool
        Whether ``trajectory.h5`` exists.
    """

    state: str
    reason: str
    status: dict[str, Any] | None = field(repr=False)
    lock: dict[str, Any] | None = field(default=None, repr=False)
    has_trajectory: bool = False

    @property
    def st(self) -> dict[str, Any]:
        """``status`` or ``{}``."""
        return self.status or {}

    @property
    def recorded(self) -> str | None:
        """The word ``status.json`` records (``None`` without one): what the runner last
        wrote, which :attr:`state` reads together with the lock and the trajectory.  Only
        the life cycle (:mod:`fcsweep.sweep.lifecycle`) decides on it; everything that
        shows or selects runs reads :attr:`state`."""
        return self.st.get("status")


def state_of(status: dict[str, Any] | None, has_trajectory: bool, live_lock: bool) -> tuple[str, str]:
    """The state word and its reason from what the files say (the module table)."""
    st = status or {}
    word = st.get("status", schema.PENDING)
    reason = str(st.get("reason", "") or "")
    if word == schema.DONE and not has_trajectory:
        word, reason = schema.CORRUPT, MISSING_TRAJECTORY
    if word != schema.DONE and live_lock:
        return schema.RUNNING, reason
    if word == schema.RUNNING:
        return schema.INTERRUPTED, reason
    return word, reason


def run_state(run_dir, stale_after: float = DEFAULT_STALE_AFTER) -> RunState:
    """The :class:`RunState` of the run in ``run_dir`` (reads only)."""
    run_dir = Path(run_dir)
    status = read_status(run_dir)
    info = lock_info(run_dir / schema.LOCK)
    live = info if info is not None and not lock_is_stale(info, stale_after) else None
    has = (run_dir / schema.TRAJECTORY).exists()
    word, reason = state_of(status, has, live is not None)
    return RunState(word, reason, status, live, has)


def refinement_points(output) -> tuple[dict[str, Any], ...]:
    """The grid points ``fcsweep refine`` recorded in ``<output>/refinement.json``, in the
    order they were added (``()`` without the file); raises
    :class:`fcsweep.io.refinement.RefinementError` for a file that cannot be read."""
    return tuple(read_points(output))
