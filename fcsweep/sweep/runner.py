"""Compute one run of a sweep: lock, resume from checkpoint, write H5MD frames, finish.

Life of a run directory ``<output>/runs/<run_id>/``:

1. ``run.lock`` is taken (:mod:`fcsweep.io.locks`); a run held by a live process is skipped.
2. Fresh start: ``trajectory.h5.partial`` is created empty.  Resume: ``checkpoint.npz`` is
   read, the partial trajectory is truncated to the frame count the checkpoint recorded,
   and the engine continues from the checkpoint (bit-for-bit the uninterrupted run).  If
   the partial file cannot be read (killed during an append) the run restarts from step 0.
3. Frames are buffered in memory and appended in one open-append-close step at every
   checkpoint (and whenever the buffer passes ``SPILL_BYTES``); then the checkpoint is
   replaced atomically.  The HDF5 file is therefore closed almost all the time.
4. When all steps are done the file is marked ``complete`` and renamed to
   ``trajectory.h5`` (atomic), then ``status.json`` says ``done``.

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
from fcsweep.io.checkpoint import load_checkpoint, save_checkpoint, split_meta, fsync_dir
from fcsweep.io.h5md import (
    append_frames,
    create_trajectory,
    frame_count,
    read_parameters,
    set_attrs,
    truncate_frames,
)
from fcsweep.io.locks import DEFAULT_STALE_AFTER, LockLost, RunLock
from fcsweep.io.status import read_status, write_status

__all__ = ["RunOutcome", "run_one", "fingerprint_of", "SPILL_BYTES"]

#: Buffered frames are written to the trajectory once they exceed this many bytes.
SPILL_BYTES = 64 * 2**20
#: Seconds between status.json refreshes while a run computes.
STATUS_INTERVAL = 2.0


@dataclass
class RunOutcome:
    """What happened to one run in one invocation.

    ``outcome`` is ``done`` (computed now), ``skipped`` (already done), ``locked`` (held by
    another live process; not a failure) or ``failed``.
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


def fingerprint_of(cfg: SweepConfig, spec: RunSpec, modes_fields: tuple[str, ...] | None = None) -> str:
    """JSON string of everything that must match for a run directory to be reused."""
    fields = modes_fields if modes_fields is not None else cfg.store.fields
    return json.dumps(
        {
            "run_id": spec.run_id,
            "seed": spec.seed,
            "steps": cfg.run.steps,
            "sample_every": cfg.run.sample_every,
            "fields": list(fields),
        },
        sort_keys=True,
    )


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


def _now() -> str:
    return time.strftime("%Y-%m-%dT%H:%M:%S%z")


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
    return par


# ---------------------------------------------------------------------------- run_one


def _is_done(st: dict | None, traj: Path, fp: str) -> bool:
    """Done with these settings; raises RunConflict if done with other settings."""
    if not st or st.get("status") != schema.DONE or not traj.exists():
        return False
    done_fp = st.get("fingerprint")
    if done_fp is None:  # status written without a fingerprint: ask the trajectory
        try:
            done_fp = read_parameters(traj).get("fingerprint")
        except Exception:  # noqa: BLE001 - unreadable: recompute
            return False
    if done_fp != fp:
        raise RunConflict(_conflict_message(traj, done_fp, fp))
    return True


def _conflict_message(path, have, want) -> str:
    try:
        a, b = json.loads(have), json.loads(want)
        diff = ", ".join(f"{k} {a.get(k)} -> {b.get(k)}" for k in sorted(b) if a.get(k) != b.get(k))
    except (TypeError, ValueError):
        diff = f"{have} -> {want}"
    return (f"{path} was computed with other run settings ({diff}); use another output "
            "directory (or --force to recompute it)")


def run_one(
    cfg: SweepConfig,
    spec: RunSpec,
    *,
    progress: Callable[[RunSpec, int, int], None] | None = None,
    stale_after: float = DEFAULT_STALE_AFTER,
    force: bool = False,
) -> RunOutcome:
    """Compute (or resume, or skip) one run; never raises for a failing simulation.

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

    Returns
    -------
    RunOutcome
    """
    run_dir = cfg.run_dir(spec.run_id)
    run_dir.mkdir(parents=True, exist_ok=True)
    traj = run_dir / schema.TRAJECTORY
    fp = fingerprint_of(cfg, spec)
    st = read_status(run_dir)
    try:
        if not force and _is_done(st, traj, fp):
            return RunOutcome(spec.index, spec.run_id, "skipped", "already done", int(st.get("steps_done", 0)))
    except RunConflict as exc:
        return RunOutcome(spec.index, spec.run_id, "failed", str(exc))
    lock = RunLock(run_dir / schema.LOCK, stale_after=stale_after)
    if not lock.acquire():
        h = lock.held_by or {}
        return RunOutcome(
            spec.index, spec.run_id, "locked",
            f"held by pid {h.get('pid')} on {h.get('host')} since {h.get('started')}",
        )
    t0 = time.time()
    lock.start_heartbeat()
    try:
        st = read_status(run_dir)  # re-check: another process may have finished meanwhile
        if not force and _is_done(st, traj, fp):
            return RunOutcome(spec.index, spec.run_id, "skipped", "already done", int(st.get("steps_done", 0)))
        return _compute(cfg, spec, run_dir, lock, st or {}, progress, force, t0)
    except LockLost as exc:  # another process owns the run now: write nothing more
        lock.token = None
        return RunOutcome(spec.index, spec.run_id, "locked", f"stopped: {exc}", 0, time.time() - t0)
    except RunConflict as exc:  # the directory holds another sweep's results: touch nothing
        return RunOutcome(spec.index, spec.run_id, "failed", str(exc), 0, time.time() - t0)
    except Exception as exc:  # noqa: BLE001 - a failed run must not stop the sweep
        reason = f"{type(exc).__name__}: {exc}"
        prev = read_status(run_dir) or {}
        write_status(
            run_dir,
            {
                **prev,
                "status": schema.FAILED,
                "reason": reason,
                "traceback": traceback.format_exc(limit=8),
                "run_id": spec.run_id,
                "index": spec.index,
                "updated": _now(),
                "host": socket.gethostname(),
                "pid": os.getpid(),
            },
        )
        return RunOutcome(spec.index, spec.run_id, "failed", reason, int(prev.get("steps_done", 0)), time.time() - t0)
    finally:
        lock.release()


def _compute(cfg, spec, run_dir: Path, lock: RunLock, prev: dict, progress, force: bool, t0: float) -> RunOutcome:
    from fcsweep.simulation import Simulation

    traj = run_dir / schema.TRAJECTORY
    partial = run_dir / schema.TRAJECTORY_PARTIAL
    ckp = run_dir / schema.CHECKPOINT
    steps, se, ce = cfg.run.steps, cfg.run.sample_every, cfg.run.checkpoint_every
    n_frames = cfg.run.n_frames
    for tmp in run_dir.glob(".*.tmp"):  # temporaries of a killed writer
        try:
            tmp.unlink()
        except OSError:
            pass

    fp_any = fingerprint_of(cfg, spec)
    notes: list[str] = []
    if traj.exists() and not force:
        # Killed after the final rename but before status.json said done?
        try:
            par = read_parameters(traj)
            if par.get("fingerprint") == fp_any and par.get("complete") and frame_count(traj) == n_frames:
                _write(run_dir, spec, schema.DONE, "", steps, steps, prev, t0, par.get("projections_final", 0),
                       {"fingerprint": fp_any})
                return RunOutcome(spec.index, spec.run_id, "done", "recovered finished trajectory", steps)
            if par.get("fingerprint") != fp_any:
                raise RunConflict(_conflict_message(traj, par.get("fingerprint"), fp_any))
        except RunConflict:
            raise
        except Exception:  # noqa: BLE001 - unreadable final file: recompute
            notes.append("unreadable trajectory.h5 replaced")
    if traj.exists():
        traj.unlink()

    sim = None
    written = 0
    if force or prev.get("run_id") != spec.run_id:
        prev = {}
    attempts = int(prev.get("attempts", 0)) + 1
    wall_before = float(prev.get("wall_seconds", 0.0))
    ck = None if force else load_checkpoint(ckp)
    if ck is not None:
        state, meta = split_meta(ck)
        if meta.get("fingerprint") != fp_any:
            raise RunConflict(_conflict_message(ckp, meta.get("fingerprint"), fp_any))
        try:
            n = frame_count(partial)
            if n < int(meta["frames"]):
                raise RuntimeError(f"partial trajectory has {n} frames, checkpoint needs {meta['frames']}")
            truncate_frames(partial, int(meta["frames"]))
            written = int(meta["frames"])
            sim = Simulation.from_checkpoint(state)
            notes.append(f"resumed from step {sim.state.step}")
        except Exception as exc:  # noqa: BLE001 - corrupt partial file: start over
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
        )
        buffer = [_snapshot(sim, fields)]
    else:
        width = int(np.asarray(sim.state.a).shape[1]) if np.ndim(sim.state.a) == 2 else 0
        fields = _fields_for(cfg, width)
        buffer = []

    info = {"notes": notes, "attempts": attempts, "wall_before": wall_before, "fingerprint": fp_any}
    _write(run_dir, spec, schema.RUNNING, "; ".join(notes), int(sim.state.step), steps, prev, t0,
           int(sim.state.projections), info)
    last_status = time.time()
    buf_bytes = sum(_frame_bytes(f) for f in buffer)
    checked_failure = False

    def commit() -> None:
        nonlocal written, buffer, buf_bytes
        lock.verify()
        written = append_frames(partial, buffer, expected_start=written, after_resize=lambda: _hook("h5-append"))
        buffer, buf_bytes = [], 0

    while sim.state.step < steps:
        sim.advance(se)
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
            save_checkpoint(
                ckp,
                sim.to_checkpoint(),
                {"frames": written, "fingerprint": fp_any, "run_id": spec.run_id, "step": step},
                before_replace=lambda _tmp: _hook("checkpoint-write"),
            )
            _hook("checkpoint")
        elif buf_bytes > SPILL_BYTES:
            commit()
        lock.heartbeat()
        if progress is not None:
            progress(spec, step, steps)
        if time.time() - last_status > STATUS_INTERVAL:
            lock.verify()
            _write(run_dir, spec, schema.RUNNING, "; ".join(notes), step, steps, prev, t0,
                   int(sim.state.projections), info)
            last_status = time.time()
    if buffer:  # only when resuming at the very end with frames pending (not expected)
        commit()

    projections = int(sim.state.projections)
    set_attrs(partial, schema.PARAMETERS, {"complete": 1, "finished": _now(), "projections_final": projections})
    os.replace(partial, traj)
    fsync_dir(run_dir)
    _hook("finalize")
    _write(run_dir, spec, schema.DONE, "; ".join(notes), steps, steps, prev, t0, projections, info)
    return RunOutcome(spec.index, spec.run_id, "done", "; ".join(notes), steps, time.time() - t0)


def _version() -> str:
    import fcsweep

    return fcsweep.__version__


def _write(run_dir, spec, status, reason, step, steps, prev, t0, projections, info=None) -> None:
    info = info or {}
    wall_before = info.get("wall_before", float(prev.get("wall_seconds", 0.0)))
    write_status(
        run_dir,
        {
            "status": status,
            "reason": reason,
            "run_id": spec.run_id,
            "index": spec.index,
            "params": dict(spec.params),
            "steps_done": int(step),
            "steps": int(steps),
            "projections": int(projections),
            "wall_seconds": round(wall_before + time.time() - t0, 3),
            "attempts": int(info.get("attempts", prev.get("attempts", 1))),
            "host": socket.gethostname(),
            "pid": os.getpid(),
            "updated": _now(),
            "fingerprint": info.get("fingerprint"),
        },
    )
