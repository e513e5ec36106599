"""What ``fcsweep simulate`` would do, without doing it (``--dry-run``).

:func:`plan_runs` reads the status, checkpoint and lock of every selected run and says,
for each, whether the next ``simulate`` starts it, resumes it (from which step), extends
it (done, but wanted longer), skips it, or cannot touch it (held by another process,
failed earlier, or computed with other run settings), with the steps left.  It reads files only; nothing is written.
"""

from __future__ import annotations

from dataclasses import dataclass

from fcsweep.config import RunSpec, SweepConfig
from fcsweep.io import schema
from fcsweep.io.checkpoint import load_checkpoint, split_meta
from fcsweep.io.locks import DEFAULT_STALE_AFTER, lock_info, lock_is_stale
from fcsweep.io.status import read_status
from fcsweep.sweep.length import extension_of
from fcsweep.sweep.runner import fingerprint_of
from fcsweep.sweep.status import settings_change

__all__ = ["PlannedRun", "plan_runs", "ACTIONS"]

#: What the next ``simulate`` does with a run.  ``extend``: done, but the config now wants
#: it longer (it continues from its final checkpoint); ``blocked``: done or checkpointed with
#: other run settings (``--force`` recomputes); ``failed``: failed earlier and not retried
#: without ``--retry-failed``; ``locked``: another live process holds it.
ACTIONS = ("start", "resume", "extend", "skip", "locked", "failed", "blocked")


@dataclass(frozen=True)
class PlannedRun:
    """One run's fate under the next ``simulate``: ``action``, the step it starts from
    and the steps it would compute, and a note for people."""

    spec: RunSpec
    action: str
    from_step: int
    steps_left: int
    note: str = ""


def _plan_one(cfg: SweepConfig, spec: RunSpec, force: bool, retry_failed: bool, stale_after: float) -> PlannedRun:
    steps = cfg.run.steps
    run_dir = cfg.run_dir(spec.run_id)
    fp = fingerprint_of(cfg, spec)
    st = read_status(run_dir) or {}
    lock = lock_info(run_dir / schema.LOCK)
    if lock is not None and not lock_is_stale(lock, stale_after):
        return PlannedRun(spec, "locked", 0, 0, f"held by pid {lock.get('pid')} on {lock.get('host')}")
    state = st.get("status")
    if state == schema.DONE and (run_dir / schema.TRAJECTORY).exists():
        change = settings_change(st.get("fingerprint"), fp)
        if force:
            return PlannedRun(spec, "start", 0, steps, "recomputed (--force)")
        if change:
            return PlannedRun(spec, "blocked", 0, 0,
                              f"computed with other run settings ({change}): --force recomputes it, "
                              "or use another output directory")
        more = extension_of(cfg.run, st)
        if more:
            done = int(st.get("steps_done", 0) or 0)
            return PlannedRun(spec, "extend", done, max(steps - done, 0), more)
        return PlannedRun(spec, "skip", steps, 0, "already done")
    if state == schema.FAILED and not (retry_failed or force):
        return PlannedRun(spec, "failed", 0, 0, f"failed earlier ({st.get('reason', '')}); --retry-failed reruns it")
    if not force and (run_dir / schema.CHECKPOINT).exists():
        ck = load_checkpoint(run_dir / schema.CHECKPOINT)
        if ck is not None:
            _, meta = split_meta(ck)
            if meta.get("fingerprint") != fp:
                change = settings_change(meta.get("fingerprint"), fp)
                return PlannedRun(spec, "blocked", 0, 0,
                                  f"checkpoint from other run settings ({change}): --force restarts it")
            step = int(meta.get("step", 0))
            return PlannedRun(spec, "resume", step, max(steps - step, 0), f"from step {step}")
    return PlannedRun(spec, "start", 0, steps, "restart" if state in (schema.FAILED, schema.RUNNING) else "")


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
