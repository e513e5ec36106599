"""What ``fcsweep simulate`` would do, without doing it (``--dry-run``).

:func:`plan_runs` reads the status, checkpoint and lock of every selected run and says,
for each, whether the next ``simulate`` starts it, resumes it (from which step), extends
it (done, but wanted longer), skips it, or cannot touch it (held by another process,
failed earlier, or computed with other run settings), with the steps left.  The decision
is :func:`fcsweep.sweep.lifecycle.assess`, the one the runner acts on.  It reads files
only; nothing is written.
"""

from __future__ import annotations

from dataclasses import dataclass

from fcsweep.config import RunSpec, SweepConfig
from fcsweep.io.locks import DEFAULT_STALE_AFTER
from fcsweep.sweep.lifecycle import ACTIONS, assess

__all__ = ["PlannedRun", "plan_runs", "ACTIONS"]


@dataclass(frozen=True)
class PlannedRun:
    """One run's fate under the next ``simulate``: ``action``, the step it starts from
    and the steps it would compute, a note for people, and the run's ``state`` (the
    word ``fcsweep status`` shows)."""

    spec: RunSpec
    action: str
    from_step: int
    steps_left: int
    note: str = ""
    state: str = ""


def _plan_one(cfg: SweepConfig, spec: RunSpec, force: bool, retry_failed: bool, stale_after: float) -> PlannedRun:
    a = assess(cfg, spec, force=force, retry_failed=retry_failed, stale_after=stale_after)
    note = a.reason
    if a.action == "failed":
        note = f"{a.reason}; --retry-failed reruns it"
    elif a.action == "start" and a.damaged is not None:
        note = f"{a.reason}; recomputed"
    return PlannedRun(spec, a.action, a.from_step, a.steps_left, note, a.state)


def plan_runs(cfg: SweepConfig, specs, *, force: bool = False, retry_failed: bool = False,
              stale_after: float = DEFAULT_STALE_AFTER) -> list[PlannedRun]:
    """The action of the next ``fcsweep simulate`` for each of ``specs`` (same order).

    Parameters
    ----------
    cfg : SweepConfig
    specs : sequence of RunSpec
        The selected runs (:func:`fcsweep.sweep.executors.select_runs`).
    force, retry_failed : bool
        As the ``simulate`` options of the same names.
    stale_after : float
        Heartbeat age (s) after which a lock no longer counts.
    """
    return [_plan_one(cfg, s, force, retry_failed, stale_after) for s in specs]
