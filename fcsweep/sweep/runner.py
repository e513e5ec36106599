"""Compute one run of a sweep: lock, resume from checkpoint, write H5MD frames, finish.

Life of a run directory ``<output>/runs/<run_id>/`` (its states, its file moves and
their transitions belong to :class:`fcsweep.io.rundir.RunDirectory`; the writes of a
computing run, in their order, to :class:`fcsweep.sweep.writer.RunWriter`):

1. ``run.lock`` is taken (:mod:`fcsweep.io.locks`); a run held by a live process is skipped.
2. Fresh start: ``trajectory.h5.partial`` is created empty.  Resume: ``checkpoint.npz`` is
   read, the partial trajectory is truncated to the frame count the checkpoint recorded,
   and the engine continues from the checkpoint (bit-for-bit the uninterrupted run).  If
   the partial file cannot be read (killed during an append) the run restarts from step 0.
3. Frames are buffered in memory and appended in one open-append-close step at every
   checkpoint (and whenever the buffer passes ``SPILL_BYTES``); then the checkpoint is
   replaced atomically.  The HDF5 file is therefore closed almost all the time.
4. With ``run.until``, at every check step (a multiple of ``until.check_every`` past
   ``until.min_steps``, and at the cap) right after the checkpoint, the run analyses the
   frames of its partial trajectory (:func:`fcsweep.results.settle.assess_trajectory`,
   the estimators of ``fcsweep analyze``) and stops when every target is met.  The
   verdict is a function of the stored frames only; a run resumed at a check step checks
   again before going on, so a killed run stops at the same step with the same bits.
5. When the run stops (cap reached or settled) the file is marked ``complete`` with its
   ``stop_reason`` and ``steps_done``, repacked into a fresh file (appends leave unused
   space behind) that replaces ``trajectory.h5`` atomically, then ``status.json`` says
   ``done``.  The final ``checkpoint.npz`` stays.
6. Extension (:mod:`fcsweep.sweep.length`): a done run that the present config wants
   longer (``run.steps`` raised; ``run.until`` changed after it settled) has its
   trajectory copied back to ``trajectory.h5.partial`` and resumes from the final
   checkpoint like an interrupted run; the frames are bit for bit those of a run with
   the new settings from the start.  A stale ``analysis.h5`` is removed.

Cost: ``status.json`` records ``cell_steps`` (N x steps in the trajectory),
``cell_steps_computed`` (all integrated, including work redone after kills),
``cpu_seconds`` (process CPU time of every attempt, checks included) and
``check_cpu_seconds`` (the part the ``until`` checks took).

Faults, each handled once in :func:`run_one`:

- a stop request (SIGTERM/SIGINT/SIGUSR1, :mod:`fcsweep.sweep.interrupt`) is checked
  between pieces of integration of about half a second: the buffered frames are
  appended, a checkpoint is written at the *current* step (the state is exact), the run
  is marked ``interrupted`` and the lock released;
- an environmental I/O error (ENOSPC, EDQUOT, EIO, EROFS) marks the run ``failed`` with
  cause ``io``; the last checkpoint and its frames stay, and the next launch resumes
  there.  Free space is checked before every write, so HDF5 never meets a full disk;
- a done run whose trajectory is damaged (checksums, truncation) is marked ``corrupt``
  and computed again (bit for bit the same, runs are deterministic).

The faults that tests make on purpose (kills at the points above, injected failures, a
slowed run) are :mod:`fcsweep.io.faults`.
"""

from __future__ import annotations

import json
import time
import traceback
from dataclasses import dataclass
from typing import Callable

from fcsweep.config import RunSpec, SweepConfig
from fcsweep.io import schema
from fcsweep.io.faults import faults
from fcsweep.io.checkpoint import load_checkpoint, split_meta
from fcsweep.io.h5md import append_frames, frame_count, read_parameters, truncate_frames, verify_trajectory
from fcsweep.io.locks import DEFAULT_STALE_AFTER, LockLost
from fcsweep.io.rundir import RunDirectory, ensure_free_space, io_error_cause
from fcsweep.sweep import interrupt
from fcsweep.sweep.length import STOP_SETTLED, STOP_STEPS, extension_of, same_physics
from fcsweep.sweep.lifecycle import assess, conflict_message, extension_blocker, fingerprint_of
from fcsweep.sweep.writer import (
    SPACE_MARGIN,
    RunWriter,
    fields_for,
    new_trajectory,
)

__all__ = ["RunOutcome", "run_one", "fingerprint_of", "trajectory_bytes", "SPILL_BYTES", "SPACE_MARGIN"]

#: Buffered frames are written to the trajectory once they exceed this many bytes.
SPILL_BYTES = 64 * 2**20
#: Seconds between status.json refreshes while a run computes.
STATUS_INTERVAL = 2.0
#: Target wall time of one piece of integration between two checks for a stop request.
PIECE_SECONDS = 0.5


@dataclass
class RunOutcome:
    """What happened to one run in one invocation.

    ``outcome`` is ``done`` (computed now), ``skipped`` (already done), ``locked`` (held by
    another live process; not a failure), ``interrupted`` (stopped by a signal, with a
    checkpoint; or not started because a stop was requested) or ``failed``.
    """

    index: int
    run_id: str
    outcome: str
    message: str = ""
    steps_done: int = 0
    wall_seconds: float = 0.0

    @property
    def ok(self) -> bool:
        return self.outcome != "failed"


class RunConflict(RuntimeError):
    """Files in the run directory were produced with different settings."""


class Interrupted(Exception):
    """A stop was requested; the run was checkpointed at ``step``."""

    def __init__(self, signal_name: str, step: int):
        super().__init__(f"{signal_name} at step {step}")
        self.signal_name, self.step = signal_name, int(step)


def trajectory_bytes(cfg: SweepConfig, spec: RunSpec) -> int:
    """Uncompressed size of one run's trajectory (an upper bound for gzip/lzf files)."""
    n = int(spec.params["N"])
    modes = int(spec.params.get("modes", 0))
    per_cell = {"position": 16, "image": 8, "theta": 8, "shape_a": 8 * max(modes - 1, 0),
                "shape_b": 8 * max(modes - 1, 0)}
    frame = 24 + n * sum(per_cell[f] for f in cfg.store.fields)
    return int(cfg.run.n_frames) * frame



# ---------------------------------------------------------------------------- run_one


def run_one(
    cfg: SweepConfig,
    spec: RunSpec,
    *,
    progress: Callable[[RunSpec, int, int], None] | None = None,
    stale_after: float = DEFAULT_STALE_AFTER,
    force: bool = False,
    stop: Callable[[], str | None] | None = None,
    retry_failed: bool = True,
) -> RunOutcome:
    """Compute (or resume, or skip) one run as :func:`fcsweep.sweep.lifecycle.assess`
    decides; never raises for a failing run.

    Parameters
    ----------
    cfg : SweepConfig
    spec : RunSpec
    progress : callable, optional
        ``progress(spec, step, steps)`` after every frame.
    stale_after : float
        Heartbeat age (s) after which another host's lock is considered stale.
    force : bool
        Recompute even if the run is done (a held lock is still respected).
    retry_failed : bool
        Rerun a run that failed for a reason a relaunch does not fix (cause other than
        "io"); if False it is reported failed without being touched.
    stop : callable, optional
        Returns the name of a requested stop (e.g. ``"SIGTERM"``) or ``None``; checked
        about every :data:`PIECE_SECONDS`.  Default: this process's signal flag
        (:func:`fcsweep.sweep.interrupt.reason`).

    Returns
    -------
    RunOutcome
    """
    stop = stop or interrupt.reason
    a = assess(cfg, spec, force=force, retry_failed=retry_failed, stale_after=stale_after)
    if a.action == "failed":
        return RunOutcome(spec.index, spec.run_id, "failed", f"{a.reason}; use --retry-failed")
    if stop():
        return RunOutcome(spec.index, spec.run_id, "interrupted", "not started")
    rd = RunDirectory(cfg.run_dir(spec.run_id), spec.run_id, spec.index, spec.params)
    try:
        rd.path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        return RunOutcome(spec.index, spec.run_id, "failed",
                          f"cannot create {rd.path}: {io_error_cause(exc) or exc}")
    early = _settled_outcome(spec, a)
    if early is not None:
        return early
    if not rd.acquire(stale_after):
        return RunOutcome(spec.index, spec.run_id, "locked", rd.held_by())
    t0 = time.time()
    try:
        # second look under the lock: another process may have finished (or repaired) it meanwhile
        a = assess(cfg, spec, force=force, retry_failed=retry_failed, stale_after=stale_after, ours=True)
        early = _settled_outcome(spec, a)
        if early is not None:
            return early
        if a.damaged is not None:
            rd.mark_corrupt(a.damaged)
            rd.remove_trajectory(analysis=False)
        out = _compute(cfg, spec, rd, a.status, progress, force or a.damaged is not None, t0, stop)
        if a.damaged is not None:
            out.message = f"recomputed damaged trajectory ({a.damaged})" + (f"; {out.message}" if out.message else "")
        return out
    except Interrupted as it:
        prev = rd.status()
        rd.mark_interrupted(it.signal_name, it.step, steps_done=it.step,
                            **{k: prev[k] for k in schema.COST_KEYS if k in prev})
        return RunOutcome(spec.index, spec.run_id, "interrupted",
                          f"{it.signal_name}: checkpoint at step {it.step}", it.step, time.time() - t0)
    except LockLost as exc:  # another process owns the run now: write nothing more
        rd.lock.token = None
        return RunOutcome(spec.index, spec.run_id, "locked", f"stopped: {exc}", 0, time.time() - t0)
    except RunConflict as exc:  # the directory holds another sweep's results: touch nothing
        return RunOutcome(spec.index, spec.run_id, "failed", str(exc), 0, time.time() - t0)
    except Exception as exc:  # noqa: BLE001 - a failed run must not stop the sweep
        cause = io_error_cause(exc)
        ck = load_checkpoint(rd.checkpoint)
        at = int(split_meta(ck)[1].get("step", 0)) if ck else 0
        if cause:
            reason = f"I/O error: {cause}"
            rd.mark_failed(reason, schema.CAUSE_IO, checkpoint_step=at)
            message = f"{reason}; the next launch resumes from step {at} once this is fixed"
        else:
            reason = message = f"{type(exc).__name__}: {exc}"
            rd.mark_failed(reason, schema.CAUSE_SIMULATION, traceback=traceback.format_exc(limit=8))
        return RunOutcome(spec.index, spec.run_id, "failed", message, at, time.time() - t0)
    finally:
        rd.release()


def _settled_outcome(spec: RunSpec, a) -> RunOutcome | None:
    """The outcome of a run the assessment settles without computing (skip, conflict,
    failed earlier), else ``None``."""
    if a.action == "skip":
        return RunOutcome(spec.index, spec.run_id, "skipped", "already done", a.from_step)
    if a.action == "blocked":
        return RunOutcome(spec.index, spec.run_id, "failed", conflict_message(*a.conflict))
    if a.action == "failed":
        return RunOutcome(spec.index, spec.run_id, "failed", f"{a.reason}; use --retry-failed")
    return None


class _Pace:
    """Steps per piece of integration so that a piece takes about PIECE_SECONDS."""

    def __init__(self, first: int):
        self.n = max(1, int(first))

    def update(self, steps: int, seconds: float) -> None:
        if steps > 0 and seconds > 0:
            self.n = int(min(1 << 22, max(1, PIECE_SECONDS * steps / seconds)))



def _reopen_for_extension(rd: RunDirectory, par: dict, fp: str) -> str | None:
    """Turn a finished trajectory back into a partial one that resumes from the final
    checkpoint; returns ``None`` on success, else why it cannot (then the run is
    recomputed from step 0, with the same bits, at full cost)."""
    done = int(par.get("steps_done", par.get("steps", -1)))
    why = extension_blocker(rd.path, done, fp)
    if why is not None:
        return why
    ensure_free_space(rd.path, rd.trajectory.stat().st_size + SPACE_MARGIN, "reopening the trajectory")
    rd.reopen()
    return None


def _compute(cfg, spec, rd: RunDirectory, prev: dict, progress, force: bool, t0: float, stop) -> RunOutcome:
    from fcsweep.simulation import Simulation

    until = cfg.run.until
    c0 = time.process_time()
    rd.remove_temporaries()

    fp_any = fingerprint_of(cfg, spec)
    notes: list[str] = []
    if prev.get("run_id") != spec.run_id:
        prev = {}
    # cost counts every attempt, recomputations (--force, damaged files) included
    cost = {k: float(prev.get(k, 0.0) or 0.0) for k in schema.COST_KEYS}
    if force:
        prev = {}
    if rd.trajectory.exists() and not force:
        recovered, force = _finished_trajectory(cfg, spec, rd, prev, fp_any, notes)
        if recovered is not None:
            return recovered
    if rd.trajectory.exists():
        rd.remove_trajectory()

    sim, written = (None, 0) if force else _resume(rd, fp_any, notes)
    fresh = sim is None
    if fresh:
        rd.start_over()
        sim = Simulation.create(int(spec.params["N"]), **spec.model_params())
        fields = new_trajectory(cfg, spec, rd, sim, fp_any)
    else:
        fields = fields_for(cfg, sim)
    w = RunWriter(cfg, spec, rd, sim, fields=fields, written=written, fingerprint=fp_any, reason="; ".join(notes),
                  cost=cost, t0=t0, c0=c0, append=append_frames)  # looked up here: fault tests replace it
    if fresh:
        w.sample()  # the frame at step 0
    rd.begin({"steps": int(cfg.run.steps), "fingerprint": fp_any, "attempts": int(prev.get("attempts", 0)) + 1,
              "until": until.as_dict() if until else None, "transient": cfg.run.transient})
    w.record(int(sim.state.step))
    stop_reason = _integrate(cfg, spec, w, progress, stop)
    if w.buffer:  # only when resuming at the very end with frames pending (not expected)
        w.commit()
    done = w.finalize(stop_reason)
    return RunOutcome(spec.index, spec.run_id, "done", w.reason, done, time.time() - t0)


def _finished_trajectory(cfg, spec, rd: RunDirectory, prev: dict, fp_any: str,
                         notes: list[str]) -> tuple[RunOutcome | None, bool]:
    """A ``trajectory.h5`` found at the start: killed after the final rename but before
    status.json said done (recovered: returns its outcome), or done and now wanted
    longer (reopened for extension), or damaged.  Returns (outcome, whether the run must
    restart from step 0 without its checkpoint); ``notes`` get what was done."""
    traj, steps, se = rd.trajectory, cfg.run.steps, cfg.run.sample_every
    try:
        par = read_parameters(traj)
        if not same_physics(par.get("fingerprint"), fp_any):
            raise RunConflict(conflict_message(traj, par.get("fingerprint"), fp_any))
        done = int(par.get("steps_done", par.get("steps", steps)))
        if verify_trajectory(traj, done // se + 1) is None:
            ended = {"steps_done": done, "stop_reason": par.get("stop_reason") or STOP_STEPS,
                     "until": par.get("until_json"), "transient": par.get("transient", cfg.run.transient)}
            extension = extension_of(cfg.run, ended)
            if extension is None:
                rd.remove_partial()
                rd.begin({"steps": steps, "fingerprint": fp_any, "attempts": int(prev.get("attempts", 1)),
                          "until": json.loads(par.get("until_json") or "null"),
                          "transient": ended["transient"]})
                rd.mark_done(steps_done=done, projections=int(par.get("projections_final", 0)),
                             stop_reason=ended["stop_reason"], reason="recovered finished trajectory",
                             **{k: prev[k] for k in schema.COST_KEYS if k in prev})
                return RunOutcome(spec.index, spec.run_id, "done", "recovered finished trajectory", done), False
            why_not = _reopen_for_extension(rd, par, fp_any)
            if why_not is None:
                notes.append(f"extended from step {done} ({extension})")
            else:
                notes.append(f"recomputed from step 0 to extend it: {why_not}")
                return None, True  # the checkpoint does not fit the trajectory: do not use it
        else:
            notes.append("damaged trajectory.h5 replaced")
    except RunConflict:
        raise
    except Exception as exc:  # noqa: BLE001 - unreadable final file: recompute
        if io_error_cause(exc):
            raise
        notes.append("damaged trajectory.h5 replaced")
    return None, False


def _resume(rd: RunDirectory, fp_any: str, notes: list[str]):
    """(engine, frames written) from the checkpoint and the partial trajectory cut back
    to the frames it covers; ``(None, 0)`` without a usable pair (the run starts over)."""
    from fcsweep.simulation import Simulation

    ck = load_checkpoint(rd.checkpoint)
    if ck is None:
        return None, 0
    state, meta = split_meta(ck)
    if not same_physics(meta.get("fingerprint"), fp_any):
        raise RunConflict(conflict_message(rd.checkpoint, meta.get("fingerprint"), fp_any))
    try:
        n = frame_count(rd.partial)
        if n < int(meta["frames"]):
            raise RuntimeError(f"partial trajectory has {n} frames, checkpoint needs {meta['frames']}")
        truncate_frames(rd.partial, int(meta["frames"]))
        sim = Simulation.from_checkpoint(state)
    except Exception as exc:  # noqa: BLE001 - corrupt partial file: start over
        if io_error_cause(exc):
            raise
        notes.append(f"restarted from step 0 ({type(exc).__name__}: {exc})")
        return None, 0
    if not any(note.startswith("extended") for note in notes):
        notes.append(f"resumed from step {sim.state.step}")
    return sim, int(meta["frames"])


def _integrate(cfg, spec, w: RunWriter, progress, stop) -> str:
    """Advance the engine, sampling, committing and checkpointing, until the step cap or
    the ``run.until`` targets are met; returns the stop reason.  On a stop request the
    frames are committed, a checkpoint is written at the current step and
    :class:`Interrupted` is raised."""
    sim = w.sim
    steps, se, ce = cfg.run.steps, cfg.run.sample_every, cfg.run.checkpoint_every
    last_status = time.time()
    stop_reason = STOP_SETTLED if w.settle(int(sim.state.step)) else STOP_STEPS
    pace = _Pace(min(se, 64))
    made = faults()  # the faults a test asked for (fcsweep.io.faults); inactive in production
    first_frame = True
    while stop_reason != STOP_SETTLED and sim.state.step < steps:
        target = min(steps, (int(sim.state.step) // se + 1) * se)
        while sim.state.step < target:
            n = min(target - int(sim.state.step), pace.n)
            t = time.perf_counter()
            sim.advance(n)
            pace.update(n, time.perf_counter() - t)
            why = stop()
            if why:
                if int(sim.state.step) == target:  # a frame is due first
                    w.sample()
                w.stop_at(int(sim.state.step))
                raise Interrupted(why, int(sim.state.step))
        if made.active and first_frame:
            made.fail_run(spec.run_id)
        first_frame = False
        w.sample()
        if made.active:
            made.after_frame()
        step = int(sim.state.step)
        if step % ce == 0 or step >= steps:
            w.commit()
            w.checkpoint(step)
            if w.settle(step):
                stop_reason = STOP_SETTLED
        elif w.buffer_bytes > SPILL_BYTES:
            w.commit()
        if progress is not None:
            progress(spec, step, steps)
        if time.time() - last_status > STATUS_INTERVAL:
            w.rd.lock.verify()
            w.record(step)
            last_status = time.time()
        why = stop()
        if why and step < steps and stop_reason != STOP_SETTLED:
            w.stop_at(step)
            raise Interrupted(why, step)
    return stop_reason
