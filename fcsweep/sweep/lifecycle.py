"""A run's life cycle in one place: what state it is in and what the next ``simulate`` does.

:func:`assess` reads one run directory (status, lock, trajectory, checkpoint; nothing is
written) and returns an :class:`Assessment`: the state word every command shows
(:func:`fcsweep.io.sweepdir.run_state`, also used by ``status``, ``analyze`` and
``aggregate``) and the action of the next ``simulate`` with the step it starts from.
The sweep runner (:func:`fcsweep.sweep.runner.run_one`) acts on it, and the dry run
(:mod:`fcsweep.sweep.plan`) prints it, so the dry run predicts what ``simulate`` does.

Actions, in the order they are decided::

    ``failed``   failed for a reason a relaunch does not fix (cause "simulation");
                 rerun only with ``--retry-failed`` (or ``--force``).  A failure
                 with cause "io" (full disk, quota...) resumes by itself.
    ``skip``     done, with these physics, long enough, trajectory sound.
    ``blocked``  done, or checkpointed, with other run settings: ``--force`` recomputes it.
    ``extend``   done, but the config wants it longer: continues from its final checkpoint.
    ``locked``   another live process holds the run.
    ``resume``   continues from its checkpoint (or finishes a trajectory written just before a
                 kill: ``steps_left`` 0).
    ``start``    computed from step 0 (fresh, ``--force``, a damaged or missing trajectory,
                 an unusable partial trajectory).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from fcsweep.config import RunSpec, SweepConfig
from fcsweep.io import schema
from fcsweep.io.checkpoint import load_checkpoint, split_meta
from fcsweep.io.h5md import frame_count, read_parameters, verify_trajectory
from fcsweep.io.locks import DEFAULT_STALE_AFTER
from fcsweep.io.rundir import RunDirectory
from fcsweep.io.sweepdir import run_state
from fcsweep.sweep.length import LENGTH_KEYS, STOP_STEPS, extension_of, frames_done, same_physics

__all__ = ["Assessment", "assess", "ACTIONS", "fingerprint_of", "conflict_message", "settings_change",
           "extension_blocker"]

#: What the next ``simulate`` does with a run (see the module docstring).
ACTIONS = ("start", "resume", "extend", "skip", "locked", "failed", "blocked")


@dataclass(frozen=True)
class Assessment:
    """State of one run and what the next ``simulate`` does with it.

    Attributes
    ----------
    state : str
        The state word of :func:`fcsweep.io.sweepdir.run_state` (what ``status`` shows).
    action : str
        One of :data:`ACTIONS`.
    from_step : int
        Step the computation starts from (``steps_done`` of a skipped run).
    steps_left : int
        Steps the next ``simulate`` integrates.
    reason : str
        For people (the dry run's note).
    damaged : str or None
        A done run's trajectory problem (missing, checksums): the runner marks the run
        ``corrupt`` and recomputes it.
    conflict : tuple or None
        ``(path, fingerprint found, fingerprint wanted)`` of a ``blocked`` run.
    status : dict
        ``status.json`` as read (``{}`` without one).
    """

    state: str
    action: str
    from_step: int
    steps_left: int
    reason: str = ""
    damaged: str | None = None
    conflict: tuple | None = field(default=None, repr=False)
    status: dict[str, Any] = field(default_factory=dict, repr=False, compare=False)


def fingerprint_of(cfg: SweepConfig, spec: RunSpec, modes_fields: tuple[str, ...] | None = None) -> str:
    """JSON string of everything that must match for a run directory to be reused: the
    physics of the trajectory frame by frame, not its length (``run.steps`` and
    ``run.until`` are left out, so a longer run continues a shorter one; see
    :func:`fcsweep.sweep.length.same_physics`)."""
    fields = modes_fields if modes_fields is not None else cfg.store.fields
    return json.dumps(
        {
            "run_id": spec.run_id,
            "seed": spec.seed,
            "sample_every": cfg.run.sample_every,
            "fields": list(fields),
        },
        sort_keys=True,
    )


def conflict_message(path, have, want) -> str:
    """The runner's message for files written with other run settings."""
    try:
        a, b = json.loads(have), json.loads(want)
        diff = ", ".join(f"{k} {a.get(k)} -> {b.get(k)}" for k in sorted(b) if a.get(k) != b.get(k)
                         and k not in LENGTH_KEYS)
    except (TypeError, ValueError):
        diff = f"{have} -> {want}"
    return (f"{path} was computed with other run settings ({diff}); use another output "
            "directory (or --force to recompute it)")


def settings_change(have: str | None, want: str) -> str:
    """``steps 2000 -> 4000`` when a done run's fingerprint differs from the config's."""
    if not have or have == want:
        return ""
    try:
        a, b = json.loads(have), json.loads(want)
    except (TypeError, ValueError):
        return "other settings"
    return ", ".join(f"{k} {a.get(k)} -> {b.get(k)}" for k in sorted(b) if a.get(k) != b.get(k))


def extension_blocker(run_dir, done: int, fp: str) -> str | None:
    """Why a finished trajectory cannot be continued from its final checkpoint (then the
    run is recomputed from step 0), or ``None``."""
    run_dir = Path(run_dir)
    ck = load_checkpoint(run_dir / schema.CHECKPOINT)
    if ck is None:
        return "no final checkpoint"
    meta = split_meta(ck)[1]
    try:
        n = frame_count(run_dir / schema.TRAJECTORY)
    except Exception:  # noqa: BLE001 - unreadable trajectory
        n = -1
    if int(meta.get("step", -1)) != done or int(meta.get("frames", -1)) != n or \
            not same_physics(meta.get("fingerprint"), fp):
        return f"final checkpoint (step {meta.get('step')}) does not match the trajectory ({done} steps)"
    return None


def _damage(rd: RunDirectory, n_frames: int, verify: bool | None) -> str | None:
    """Problem of a done run's trajectory: with ``verify`` None a full checksum read
    unless the file still has the size and mtime recorded when it was finished."""
    if verify is False or (verify is None and rd.unchanged_since_done()):
        return None
    return rd.verify(n_frames)


def _done_fingerprint(st: dict, traj: Path) -> str | None:
    """Fingerprint of a done run (from its trajectory for status files without one);
    ``None`` when it cannot be read (the run is then recomputed)."""
    fp = st.get("fingerprint")
    if fp is not None:
        return fp
    try:
        return read_parameters(traj).get("fingerprint")
    except Exception:  # noqa: BLE001 - unreadable
        return None


@dataclass(frozen=True)
class _Look:
    """What :func:`assess` read of one run, and how it words an :class:`Assessment`."""

    cfg: SweepConfig
    rd: RunDirectory
    rs: Any  # fcsweep.io.sweepdir.RunState
    fp: str
    lock: dict | None
    force: bool
    retry_failed: bool
    verify: bool | None

    @property
    def st(self) -> dict[str, Any]:
        return self.rs.st

    @property
    def word(self) -> str | None:
        """The word ``status.json`` records (what the runner last wrote), before
        :func:`fcsweep.io.sweepdir.run_state` reads it together with lock and trajectory."""
        return self.rs.recorded

    def out(self, action: str, from_step: int, reason: str = "", left: int | None = None, **kw) -> Assessment:
        from_step = int(from_step)
        if left is None:
            left = max(self.cfg.run.steps - from_step, 0) if action in ("start", "resume", "extend") else 0
        return Assessment(self.rs.state, action, from_step, int(left), reason, status=self.st, **kw)

    def locked(self) -> Assessment | None:
        lock = self.lock
        return None if lock is None else self.out("locked", 0, f"held by pid {lock.get('pid')} on {lock.get('host')}")

    def restart(self) -> Assessment:
        return self.out("start", 0, "restart" if self.word in (schema.FAILED, schema.RUNNING) else "")


def assess(cfg: SweepConfig, spec: RunSpec, *, force: bool = False, retry_failed: bool = False,
           stale_after: float = DEFAULT_STALE_AFTER, verify: bool | None = None,
           ours: bool = False) -> Assessment:
    """State of run ``spec`` and what the next ``simulate`` does with it (reads only).

    The steps, in the order of the module docstring: :func:`_failed_earlier`,
    :func:`_done_run`, a live lock, :func:`_done_without_trajectory`, ``--force``,
    :func:`_finished_unrecorded` (killed between the final rename and the status write),
    :func:`_from_checkpoint`, else a fresh start.

    Parameters
    ----------
    cfg : SweepConfig
    spec : RunSpec
    force, retry_failed : bool
        As the ``simulate`` options of the same names.
    stale_after : float
        Heartbeat age (s) after which a lock no longer counts.
    verify : bool or None
        Checksums of a done trajectory: ``None`` read them only when its size or mtime
        changed since it finished (what ``simulate`` does), ``True`` always, ``False`` never.
    ours : bool
        The caller holds the run's lock (the runner's second look): the lock is ignored.

    Returns
    -------
    Assessment
    """
    rd = RunDirectory(cfg.run_dir(spec.run_id), spec.run_id, spec.index, spec.params)
    rs = run_state(rd.path, stale_after)
    look = _Look(cfg, rd, rs, fingerprint_of(cfg, spec), None if ours else rs.lock, force, retry_failed, verify)
    for step in (_failed_earlier, _done_run, _Look.locked, _done_without_trajectory, _forced,
                 _finished_unrecorded, _from_checkpoint):
        a = step(look)
        if a is not None:
            return a
    return look.restart()


def _failed_earlier(look: _Look) -> Assessment | None:
    """A failure a relaunch does not fix, without ``--retry-failed`` / ``--force``."""
    st = look.st
    if look.word == schema.FAILED and st.get("cause") != schema.CAUSE_IO and not (look.retry_failed or look.force):
        return look.out("failed", 0, f"failed earlier ({st.get('reason', '')})")
    return None


def _done_run(look: _Look) -> Assessment | None:
    """A done run with its trajectory: blocked, skipped, held, recomputed or extended
    (``None`` without a readable fingerprint: the later steps decide)."""
    if not (look.word == schema.DONE and not look.force and look.rs.has_trajectory):
        return None
    st, rd, fp, cfg = look.st, look.rd, look.fp, look.cfg
    done_fp = _done_fingerprint(st, rd.trajectory)
    if done_fp is None:
        return None
    if not same_physics(done_fp, fp):
        return look.out("blocked", 0, f"computed with other run settings ({settings_change(done_fp, fp)}): "
                                      "--force recomputes it, or use another output directory",
                        conflict=(rd.trajectory, done_fp, fp))
    done = int(st.get("steps_done", 0) or 0)
    more = extension_of(cfg.run, st)
    problem = _damage(rd, frames_done(cfg.run, st) if more is None else done // cfg.run.sample_every + 1,
                      look.verify)
    if problem is None and more is None:
        return look.out("skip", int(st.get("steps_done", 0)), "already done")
    locked = look.locked()
    if locked is not None:
        return locked
    if problem is not None:
        return look.out("start", 0, f"trajectory.h5 damaged: {problem}", damaged=problem)
    why = extension_blocker(rd.path, done, fp)
    if why is not None:
        return look.out("start", 0, f"recomputed from step 0 to extend it: {why}")
    return look.out("extend", done, more)


def _done_without_trajectory(look: _Look) -> Assessment | None:
    """A done run whose trajectory.h5 is gone: recomputed."""
    if look.word == schema.DONE and not look.force and not look.rs.has_trajectory:
        return look.out("start", 0, look.rs.reason, damaged="trajectory.h5 is missing")
    return None


def _forced(look: _Look) -> Assessment | None:
    """``--force``: computed from step 0."""
    if not look.force:
        return None
    if look.word == schema.DONE and look.rs.has_trajectory:
        return look.out("start", 0, "recomputed (--force)")
    return look.restart()


def _finished_unrecorded(look: _Look) -> Assessment | None:
    """A trajectory.h5 whose run was killed after the final rename, before status.json
    said done: resumed with nothing left, extended, or blocked (``None`` when it is
    unreadable or damaged: the checkpoint decides)."""
    if not look.rs.has_trajectory:
        return None
    rd, fp, cfg = look.rd, look.fp, look.cfg
    try:
        par = read_parameters(rd.trajectory)
    except Exception:  # noqa: BLE001 - unreadable: recomputed (later steps)
        return None
    if not same_physics(par.get("fingerprint"), fp):
        return look.out("blocked", 0, f"computed with other run settings "
                                      f"({settings_change(par.get('fingerprint'), fp)}): --force recomputes "
                                      "it, or use another output directory",
                        conflict=(rd.trajectory, par.get("fingerprint"), fp))
    done = int(par.get("steps_done", par.get("steps", cfg.run.steps)))
    if verify_trajectory(rd.trajectory, done // cfg.run.sample_every + 1) is not None:
        return None
    ended = {"steps_done": done, "stop_reason": par.get("stop_reason") or STOP_STEPS,
             "until": par.get("until_json"), "transient": par.get("transient", cfg.run.transient)}
    more = extension_of(cfg.run, ended)
    if more is None:
        return look.out("resume", done, "recovered finished trajectory", left=0)
    why = extension_blocker(rd.path, done, fp)
    if why is not None:
        return look.out("start", 0, f"recomputed from step 0 to extend it: {why}")
    return look.out("extend", done, more)


def _from_checkpoint(look: _Look) -> Assessment | None:
    """A checkpoint (no trajectory, or a damaged one that the runner removes): resumed
    from it, restarted when its partial trajectory is unusable, or blocked."""
    rd, fp = look.rd, look.fp
    ck = load_checkpoint(rd.checkpoint, keys=[f"_sweep_{k}" for k in ("fingerprint", "frames", "step")])
    if ck is None:
        return None
    meta = split_meta(ck)[1]
    if not same_physics(meta.get("fingerprint"), fp):
        return look.out("blocked", 0, f"checkpoint from other run settings "
                                      f"({settings_change(meta.get('fingerprint'), fp)}): --force restarts it",
                        conflict=(rd.checkpoint, meta.get("fingerprint"), fp))
    try:
        n = frame_count(rd.partial)
    except Exception as exc:  # noqa: BLE001 - missing or unreadable partial trajectory
        return look.out("start", 0, f"restart ({type(exc).__name__}: no usable partial trajectory)")
    if n < int(meta.get("frames", 0)):
        return look.out("start", 0, f"restart (partial trajectory has {n} frames, checkpoint needs "
                                    f"{meta.get('frames')})")
    step = int(meta.get("step", 0))
    return look.out("resume", step, f"from step {step}")
