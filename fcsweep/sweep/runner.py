"""Compute one run of a sweep: lock, resume from checkpoint, write H5MD frames, finish.

Life of a run directory ``<output>/runs/<run_id>/`` (its states and their transitions
belong to :class:`fcsweep.io.rundir.RunDirectory`):

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
   frames of its partial trajectory (:func:`fcsweep.analysis.settle.assess_trajectory`,
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

Testing hooks (environment variables, read at run time):

``FCSWEEP_FAIL_RUN_IDS``
    Comma-separated run ids that raise an injected ``RuntimeError`` after their first
    frame (failed-run isolation tests).
``FCSWEEP_TEST_KILL_AT``
    ``POINT:K`` -- the process SIGKILLs itself the K-th time it reaches POINT, one of
    ``frame`` (a frame was sampled), ``h5-append`` (datasets grown, data not yet written),
    ``checkpoint-write`` (temporary checkpoint written, not yet renamed), ``checkpoint``
    (checkpoint in place), ``finalize`` (trajectory renamed, status not yet written).
``FCSWEEP_TEST_SLOW``
    Seconds to sleep after each frame, so that tests can signal a run mid-way.
"""

from __future__ import annotations

import functools
import json
import os
import signal
import socket
import time
import traceback
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import numpy as np

from fcsweep.config import RunSpec, SweepConfig
from fcsweep.io import schema
from fcsweep.io.checkpoint import load_checkpoint, save_checkpoint, split_meta
from fcsweep.io.h5md import (
    append_frames,
    create_trajectory,
    frame_count,
    read_parameters,
    repack,
    seq_path,
    set_attrs,
    truncate_frames,
    verify_trajectory,
)
from fcsweep.io.locks import DEFAULT_STALE_AFTER, LockLost
from fcsweep.io.rundir import RunDirectory, ensure_free_space, io_error_cause, now_iso
from fcsweep.io.sweepdir import atomic_write, fsync_dir
from fcsweep.sweep import interrupt
from fcsweep.sweep.length import STOP_SETTLED, STOP_STEPS, extension_of, same_physics
from fcsweep.sweep.lifecycle import assess, conflict_message, extension_blocker, fingerprint_of

__all__ = ["RunOutcome", "run_one", "fingerprint_of", "trajectory_bytes", "SPILL_BYTES"]

#: Buffered frames are written to the trajectory once they exceed this many bytes.
SPILL_BYTES = 64 * 2**20
#: Seconds between status.json refreshes while a run computes.
STATUS_INTERVAL = 2.0
#: Target wall time of one piece of integration between two checks for a stop request.
PIECE_SECONDS = 0.5
#: Bytes kept free beyond every write (HDF5 metadata, status files).
SPACE_MARGIN = 4 << 20


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


# ------------------------------------------------------------------------- test hooks

_kill_counts: dict[str, int] = {}


def _hook(point: str) -> None:
    spec = os.environ.get("FCSWEEP_TEST_KILL_AT")
    if not spec:
        return
    name, _, k = spec.partition(":")
    if name != point:
        return
    _kill_counts[point] = _kill_counts.get(point, 0) + 1
    if _kill_counts[point] == int(k or 1):
        os.kill(os.getpid(), signal.SIGKILL)


def _slow() -> None:
    delay = os.environ.get("FCSWEEP_TEST_SLOW")
    if delay:
        time.sleep(float(delay))


def _injected_failure(run_id: str) -> None:
    ids = os.environ.get("FCSWEEP_FAIL_RUN_IDS", "")
    if run_id in {s.strip() for s in ids.split(",") if s.strip()}:
        raise RuntimeError(f"injected failure for run {run_id} (FCSWEEP_FAIL_RUN_IDS)")


# ---------------------------------------------------------------------------- helpers


_now = now_iso


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


@functools.lru_cache(maxsize=1)
def git_commit() -> str | None:
    """Commit of the fcsweep source tree when it is a git checkout (``+dirty`` if it has
    uncommitted changes), else ``None``."""
    import subprocess

    import fcsweep

    src = Path(fcsweep.__file__).resolve().parent
    try:
        head = subprocess.run(["git", "-C", str(src), "rev-parse", "HEAD"], capture_output=True, text=True,
                              timeout=10)
        if head.returncode != 0:
            return None
        dirty = subprocess.run(["git", "-C", str(src), "status", "--porcelain", "--untracked-files=no", "."],
                               capture_output=True, text=True, timeout=10)
    except (OSError, subprocess.SubprocessError):
        return None
    return head.stdout.strip() + ("+dirty" if dirty.stdout.strip() else "")


def _fields_for(cfg: SweepConfig, modes_width: int) -> tuple[str, ...]:
    if modes_width == 0:  # rigid discs: no shape modes to store
        return tuple(f for f in cfg.store.fields if f not in ("shape_a", "shape_b"))
    return cfg.store.fields


def _snapshot(sim, fields) -> dict[str, Any]:
    st = sim.state
    src = {
        "position": st.pos,
        "image": st.image,
        "theta": st.theta,
        "shape_a": st.a,
        "shape_b": st.b,
    }
    frame = {name: np.array(src[name], copy=True) for name in fields}
    frame["step"] = int(st.step)
    frame["time"] = float(st.step) * float(sim.params.dt)
    frame["projections"] = int(st.projections)
    return frame


def _frame_bytes(frame) -> int:
    return sum(v.nbytes for v in frame.values() if isinstance(v, np.ndarray))


def _parameters(cfg: SweepConfig, spec: RunSpec, fields, fingerprint: str) -> dict[str, Any]:
    import fcsweep

    par = dict(spec.params)
    par.update(
        steps=cfg.run.steps,
        sample_every=cfg.run.sample_every,
        checkpoint_every=cfg.run.checkpoint_every,
        transient=cfg.run.transient,
        until_json=_until_meta(cfg),
        run_id=spec.run_id,
        replicate=spec.replicate,
        base_seed=cfg.seed,
        swept=json.dumps(list(spec.swept)),
        fields=json.dumps(list(fields)),
        fcsweep_version=fcsweep.__version__,
        created=_now(),
        host=socket.gethostname(),
        config_json=json.dumps(cfg.to_dict(), sort_keys=True),
        fingerprint=fingerprint,
        complete=0,
    )
    commit = git_commit()
    if commit:
        par["git_commit"] = commit
    return par


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
            rd.trajectory.unlink(missing_ok=True)
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


def _cleanup_temporaries(run_dir: Path) -> None:
    for tmp in run_dir.glob(".*.tmp"):  # temporaries of a killed writer
        try:
            tmp.unlink()
        except OSError:
            pass


def _until_meta(cfg) -> str:
    """``run.until`` as the JSON string stored in ``/parameters`` (``"null"`` without)."""
    return json.dumps(cfg.run.until.as_dict() if cfg.run.until else None, sort_keys=True)


def _reopen_for_extension(cfg, spec, rd: RunDirectory, par: dict, fp: str) -> str | None:
    """Turn a finished trajectory back into a partial one that resumes from the final
    checkpoint; returns ``None`` on success, else why it cannot (then the run is
    recomputed from step 0, with the same bits, at full cost)."""
    done = int(par.get("steps_done", par.get("steps", -1)))
    why = extension_blocker(rd.path, done, fp)
    if why is not None:
        return why
    ensure_free_space(rd.path, rd.trajectory.stat().st_size + SPACE_MARGIN, "reopening the trajectory")

    def reopen(tmp: Path) -> None:
        repack(rd.trajectory, tmp)
        set_attrs(tmp, schema.PARAMETERS, {"complete": 0, "stop_reason": ""})

    atomic_write(rd.partial, reopen)
    fsync_dir(rd.path)
    for name in (schema.ANALYSIS, schema.ANALYSIS_ERROR):  # they describe the shorter run
        (rd.path / name).unlink(missing_ok=True)
    rd.trajectory.unlink()
    return None


def _compute(cfg, spec, rd: RunDirectory, prev: dict, progress, force: bool, t0: float, stop) -> RunOutcome:
    from fcsweep.simulation import Simulation

    traj, partial, ckp = rd.trajectory, rd.partial, rd.checkpoint
    steps, se, ce = cfg.run.steps, cfg.run.sample_every, cfg.run.checkpoint_every
    until = cfg.run.until
    c0 = time.process_time()
    _cleanup_temporaries(rd.path)

    fp_any = fingerprint_of(cfg, spec)
    notes: list[str] = []
    if prev.get("run_id") != spec.run_id:
        prev = {}
    # cost counts every attempt, recomputations (--force, damaged files) included
    cost = {k: float(prev.get(k, 0.0) or 0.0) for k in schema.COST_KEYS}
    if force:
        prev = {}
    if traj.exists() and not force:
        # Killed after the final rename but before status.json said done?  Or done and
        # now wanted longer (extension)?
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
                    if partial.exists():
                        partial.unlink()
                    rd.begin({"steps": steps, "fingerprint": fp_any, "attempts": int(prev.get("attempts", 1)),
                              "until": json.loads(par.get("until_json") or "null"),
                              "transient": ended["transient"]})
                    rd.mark_done(steps_done=done, projections=int(par.get("projections_final", 0)),
                                 stop_reason=ended["stop_reason"], reason="recovered finished trajectory",
                                 **{k: prev[k] for k in schema.COST_KEYS if k in prev})
                    return RunOutcome(spec.index, spec.run_id, "done", "recovered finished trajectory", done)
                why_not = _reopen_for_extension(cfg, spec, rd, par, fp_any)
                if why_not is None:
                    notes.append(f"extended from step {done} ({extension})")
                else:
                    notes.append(f"recomputed from step 0 to extend it: {why_not}")
                    force = True  # the checkpoint does not fit the trajectory: do not use it
            else:
                notes.append("damaged trajectory.h5 replaced")
        except RunConflict:
            raise
        except Exception as exc:  # noqa: BLE001 - unreadable final file: recompute
            if io_error_cause(exc):
                raise
            notes.append("damaged trajectory.h5 replaced")
    if traj.exists():
        traj.unlink()
        for name in (schema.ANALYSIS, schema.ANALYSIS_ERROR):
            (rd.path / name).unlink(missing_ok=True)

    sim = None
    written = 0
    attempts = int(prev.get("attempts", 0)) + 1
    ck = None if force else load_checkpoint(ckp)
    if ck is not None:
        state, meta = split_meta(ck)
        if not same_physics(meta.get("fingerprint"), fp_any):
            raise RunConflict(conflict_message(ckp, meta.get("fingerprint"), fp_any))
        try:
            n = frame_count(partial)
            if n < int(meta["frames"]):
                raise RuntimeError(f"partial trajectory has {n} frames, checkpoint needs {meta['frames']}")
            truncate_frames(partial, int(meta["frames"]))
            written = int(meta["frames"])
            sim = Simulation.from_checkpoint(state)
            if not any(n.startswith("extended") for n in notes):
                notes.append(f"resumed from step {sim.state.step}")
        except Exception as exc:  # noqa: BLE001 - corrupt partial file: start over
            if io_error_cause(exc):
                raise
            notes.append(f"restarted from step 0 ({type(exc).__name__}: {exc})")
            sim = None
            written = 0
    if sim is None:
        for p in (partial, ckp):
            if p.exists():
                p.unlink()
        sim = Simulation.from_lattice(int(spec.params["N"]), **spec.model_params())
        width = int(np.asarray(sim.state.a).shape[1]) if np.ndim(sim.state.a) == 2 else 0
        fields = _fields_for(cfg, width)
        ensure_free_space(rd.path, SPACE_MARGIN, "a new trajectory")
        create_trajectory(
            partial,
            n_cells=int(spec.params["N"]),
            box=np.asarray(sim.params.box, dtype=float),
            modes_width=width,
            fields=fields,
            parameters=_parameters(cfg, spec, fields, fp_any),
            dt=float(sim.params.dt),
            compression=cfg.store.compression,
            compression_level=cfg.store.compression_level,
            creator_version=_version(),
            frames_per_chunk=max(1, ce // se),
        )
        buffer = [_snapshot(sim, fields)]
    else:
        width = int(np.asarray(sim.state.a).shape[1]) if np.ndim(sim.state.a) == 2 else 0
        fields = _fields_for(cfg, width)
        buffer = []

    n_cells = int(spec.params["N"])
    start_step = int(sim.state.step)
    rd.begin({"steps": int(steps), "fingerprint": fp_any, "attempts": attempts,
              "until": until.as_dict() if until else None, "transient": cfg.run.transient})
    reason = "; ".join(notes)
    last_check: dict[str, Any] = {}

    def costs(step: int) -> dict[str, Any]:
        return {"wall_seconds": round(cost["wall_seconds"] + time.time() - t0, 3),
                "cpu_seconds": round(cost["cpu_seconds"] + time.process_time() - c0, 3),
                "check_cpu_seconds": round(cost["check_cpu_seconds"], 3),
                "cell_steps": n_cells * int(step),
                "cell_steps_computed": int(cost["cell_steps_computed"]) + n_cells * (int(step) - start_step)}

    def record(step: int) -> None:
        rd.mark_running(reason=reason, steps_done=int(step), projections=int(sim.state.projections),
                        **costs(step), **({"check": last_check} if last_check else {}))

    record(int(sim.state.step))
    last_status = time.time()
    buf_bytes = sum(_frame_bytes(f) for f in buffer)
    checked_failure = False

    def commit() -> None:
        nonlocal written, buffer, buf_bytes
        rd.lock.verify()
        ensure_free_space(partial, buf_bytes + SPACE_MARGIN, f"appending {len(buffer)} frame(s)")
        written = append_frames(partial, buffer, expected_start=written, after_resize=lambda: _hook("h5-append"))
        buffer, buf_bytes = [], 0

    def checkpoint(step: int) -> None:
        state = sim.to_checkpoint()
        need = sum(np.asarray(v).nbytes for v in state.values()) + SPACE_MARGIN
        ensure_free_space(ckp, need, "the checkpoint")
        save_checkpoint(ckp, state, {"frames": written, "fingerprint": fp_any, "run_id": spec.run_id, "step": step},
                        before_replace=lambda _tmp: _hook("checkpoint-write"))
        _hook("checkpoint")
        record(step)

    def settled(step: int) -> bool:
        """The ``run.until`` check at a check step (frames up to ``step`` committed)."""
        nonlocal last_check
        if until is None or not until.is_check_step(step, steps) or buffer:
            return False
        c = time.process_time()
        verdict = _assess(partial, cfg)
        cost["check_cpu_seconds"] += time.process_time() - c
        last_check = {"step": int(step), "settled": verdict.settled, "unmet": list(verdict.unmet),
                      **{k: (None if not np.isfinite(v) else round(float(v), 6)) for k, v in verdict.values.items()}}
        record(step)
        return verdict.settled

    stop_reason = STOP_SETTLED if settled(int(sim.state.step)) else STOP_STEPS
    pace = _Pace(min(se, 64))
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
                    buffer.append(_snapshot(sim, fields))
                if buffer:
                    commit()
                checkpoint(int(sim.state.step))
                raise Interrupted(why, int(sim.state.step))
        if not checked_failure:
            checked_failure = True
            _injected_failure(spec.run_id)
        frame = _snapshot(sim, fields)
        buffer.append(frame)
        buf_bytes += _frame_bytes(frame)
        _hook("frame")
        _slow()
        step = int(sim.state.step)
        if step % ce == 0 or step >= steps:
            commit()
            checkpoint(step)
            if settled(step):
                stop_reason = STOP_SETTLED
        elif buf_bytes > SPILL_BYTES:
            commit()
        if progress is not None:
            progress(spec, step, steps)
        if time.time() - last_status > STATUS_INTERVAL:
            rd.lock.verify()
            record(step)
            last_status = time.time()
        why = stop()
        if why and step < steps and stop_reason != STOP_SETTLED:
            if buffer:
                commit()
            checkpoint(step)
            raise Interrupted(why, step)
    if buffer:  # only when resuming at the very end with frames pending (not expected)
        commit()

    done = int(sim.state.step)
    projections = int(sim.state.projections)
    set_attrs(partial, schema.PARAMETERS, {
        "complete": 1, "finished": _now(), "projections_final": projections, "stop_reason": stop_reason,
        "steps_done": done, "steps": steps, "checkpoint_every": ce, "transient": cfg.run.transient,
        "until_json": _until_meta(cfg), "fingerprint": fp_any,
        "config_json": json.dumps(cfg.to_dict(), sort_keys=True)})
    ensure_free_space(rd.path, partial.stat().st_size + SPACE_MARGIN, "repacking the finished trajectory")
    atomic_write(traj, lambda tmp: repack(partial, tmp))
    partial.unlink()
    seq_path(partial).unlink(missing_ok=True)  # live readers' write counter (io.h5md)
    fsync_dir(rd.path)
    _hook("finalize")
    rd.mark_done(reason=reason, steps_done=done, projections=projections, stop_reason=stop_reason,
                 **costs(done), **({"check": last_check} if last_check else {}))
    return RunOutcome(spec.index, spec.run_id, "done", reason, done, time.time() - t0)


def _assess(partial: Path, cfg: SweepConfig):
    """Verdict of the ``run.until`` check on the frames of ``partial``.  freud runs on one
    thread: its parallel reductions could differ in the last bits between thread counts,
    and the verdict must not depend on the machine a resumed run lands on."""
    from fcsweep.analysis.settle import assess_trajectory

    until = cfg.run.until
    return assess_trajectory(partial, transient=cfg.run.transient, confidence=until.confidence,
                             rel_error=dict(until.rel_error), threads=1)


def _version() -> str:
    import fcsweep

    return fcsweep.__version__
