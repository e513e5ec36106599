"""The write path of one computing run: frames, checkpoints, status and the final file.

:class:`RunWriter` holds what :func:`fcsweep.sweep.runner.run_one` writes while it
integrates -- the frames buffered since the last append, the number already committed to
``trajectory.h5.partial``, the run's cost and the last ``run.until`` verdict -- and
decides the order of the writes (frames before the checkpoint that counts them, the
checkpoint before the status that cites it).  The moves of the files themselves belong to
:class:`fcsweep.io.rundir.RunDirectory`.  The kills that tests ask for at
its points (``h5-append``, ``checkpoint-write``, ``checkpoint``, ``finalize``) are
:mod:`fcsweep.io.faults`.
"""

from __future__ import annotations

import functools
import json
import socket
import time
from pathlib import Path
from typing import Any, Callable

import numpy as np

from fcsweep.config import RunSpec, SweepConfig
from fcsweep.io import schema
from fcsweep.io.faults import faults
from fcsweep.io.h5md import append_frames, create_trajectory, set_attrs
from fcsweep.io.rundir import RunDirectory, ensure_free_space, now_iso

__all__ = ["RunWriter", "new_trajectory", "snapshot", "fields_for", "SPACE_MARGIN"]

#: Bytes kept free beyond every write (HDF5 metadata, status files).
SPACE_MARGIN = 4 << 20

# ------------------------------------------------------------------ what gets written


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


def fields_for(cfg: SweepConfig, sim) -> tuple[str, ...]:
    """The stored fields of ``cfg`` that the engine ``sim`` has (rigid discs: no shape modes)."""
    if _modes_width(sim) == 0:
        return tuple(f for f in cfg.store.fields if f not in ("shape_a", "shape_b"))
    return cfg.store.fields


def _modes_width(sim) -> int:
    return int(np.asarray(sim.state.a).shape[1]) if np.ndim(sim.state.a) == 2 else 0


def snapshot(sim, fields) -> dict[str, Any]:
    """One frame of the engine's present state: a copy of each field, step, time, projections."""
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


def until_meta(cfg) -> str:
    """``run.until`` as the JSON string stored in ``/parameters`` (``"null"`` without)."""
    return json.dumps(cfg.run.until.as_dict() if cfg.run.until else None, sort_keys=True)


def _version() -> str:
    import fcsweep

    return fcsweep.__version__


def _parameters(cfg: SweepConfig, spec: RunSpec, fields, fingerprint: str) -> dict[str, Any]:
    par = dict(spec.params)
    par.update(
        steps=cfg.run.steps,
        sample_every=cfg.run.sample_every,
        checkpoint_every=cfg.run.checkpoint_every,
        transient=cfg.run.transient,
        until_json=until_meta(cfg),
        run_id=spec.run_id,
        replicate=spec.replicate,
        base_seed=cfg.seed,
        swept=json.dumps(list(spec.swept)),
        fields=json.dumps(list(fields)),
        fcsweep_version=_version(),
        created=now_iso(),
        host=socket.gethostname(),
        config_json=json.dumps(cfg.to_dict(), sort_keys=True),
        fingerprint=fingerprint,
        complete=0,
    )
    commit = git_commit()
    if commit:
        par["git_commit"] = commit
    return par


def new_trajectory(cfg: SweepConfig, spec: RunSpec, rd: RunDirectory, sim, fingerprint: str) -> tuple[str, ...]:
    """Create an empty ``trajectory.h5.partial`` for a run starting at step 0 with engine
    ``sim``; returns the fields it stores."""
    fields = fields_for(cfg, sim)
    ensure_free_space(rd.path, SPACE_MARGIN, "a new trajectory")
    create_trajectory(
        rd.partial,
        n_cells=int(spec.params["N"]),
        box=np.asarray(sim.params.box, dtype=float),
        modes_width=_modes_width(sim),
        fields=fields,
        parameters=_parameters(cfg, spec, fields, fingerprint),
        dt=float(sim.params.dt),
        compression=cfg.store.compression,
        compression_level=cfg.store.compression_level,
        creator_version=_version(),
        frames_per_chunk=max(1, cfg.run.checkpoint_every // cfg.run.sample_every),
        radii=getattr(sim, "radii", None),
    )
    return fields


def _assess(partial: Path, cfg: SweepConfig):
    """Verdict of the ``run.until`` check on the frames of ``partial``.  freud runs on one
    thread: its parallel reductions could differ in the last bits between thread counts,
    and the verdict must not depend on the machine a resumed run lands on."""
    from fcsweep.results.settle import assess_trajectory

    until = cfg.run.until
    return assess_trajectory(partial, transient=cfg.run.transient, confidence=until.confidence,
                             rel_error=dict(until.rel_error), threads=1, settings=cfg.analysis.config_dict())


# --------------------------------------------------------------------------- RunWriter


class RunWriter:
    """The writes of one computing run, in their order.

    Parameters
    ----------
    cfg : SweepConfig
    spec : RunSpec
    rd : RunDirectory
        The run's directory; its lock is held.
    sim : Simulation
        The engine, at the step the run starts or resumes from.
    fields : tuple of str
        Fields stored per frame.
    written : int
        Frames already in ``trajectory.h5.partial``.
    fingerprint : str
        Settings fingerprint, stored with every checkpoint.
    reason : str
        Note carried by every status write (e.g. ``resumed from step 400``).
    cost : dict
        Cost of earlier attempts (:data:`fcsweep.io.schema.COST_KEYS`); this attempt's is added.
    t0, c0 : float
        Wall time (``time.time()``) and process CPU time (``time.process_time()``) when
        this attempt began.
    append : callable
        The frame appender, :func:`fcsweep.io.h5md.append_frames` (a parameter so that
        fault tests can make it fail).

    Attributes
    ----------
    buffer : list of dict
        Frames sampled and not yet appended; ``buffer_bytes`` their size.
    last_check : dict
        The last ``run.until`` verdict (``{}`` before the first check).
    """

    def __init__(self, cfg: SweepConfig, spec: RunSpec, rd: RunDirectory, sim, *, fields, written: int,
                 fingerprint: str, reason: str, cost: dict[str, float], t0: float, c0: float,
                 append: Callable[..., int] = append_frames):
        self.cfg, self.spec, self.rd, self.sim = cfg, spec, rd, sim
        self.fields = tuple(fields)
        self.written = int(written)
        self.fingerprint = fingerprint
        self.reason = reason
        self.cost = cost
        self.t0, self.c0 = t0, c0
        self.start_step = int(sim.state.step)
        self.n_cells = int(spec.params["N"])
        self.buffer: list[dict[str, Any]] = []
        self.buffer_bytes = 0
        self.last_check: dict[str, Any] = {}
        self._append = append

    def sample(self) -> None:
        """Buffer a frame of the engine's present state."""
        frame = snapshot(self.sim, self.fields)
        self.buffer.append(frame)
        self.buffer_bytes += _frame_bytes(frame)

    def costs(self, step: int) -> dict[str, Any]:
        """Cost of the run so far, every attempt included, with ``step`` steps in its trajectory."""
        cost = self.cost
        return {"wall_seconds": round(cost["wall_seconds"] + time.time() - self.t0, 3),
                "cpu_seconds": round(cost["cpu_seconds"] + time.process_time() - self.c0, 3),
                "check_cpu_seconds": round(cost["check_cpu_seconds"], 3),
                "cell_steps": self.n_cells * int(step),
                "cell_steps_computed": int(cost["cell_steps_computed"])
                + self.n_cells * (int(step) - self.start_step)}

    def record(self, step: int) -> None:
        """Write ``status.json``: running, ``step`` steps done, cost, last check."""
        self.rd.mark_running(reason=self.reason, steps_done=int(step), projections=int(self.sim.state.projections),
                             **self.costs(step), **({"check": self.last_check} if self.last_check else {}))

    def commit(self) -> None:
        """Append the buffered frames to the partial trajectory (the lock must still be ours)."""
        self.rd.lock.verify()
        ensure_free_space(self.rd.partial, self.buffer_bytes + SPACE_MARGIN,
                          f"appending {len(self.buffer)} frame(s)")
        self.written = self._append(self.rd.partial, self.buffer, expected_start=self.written,
                                    after_resize=lambda: faults().kill("h5-append"))
        self.buffer, self.buffer_bytes = [], 0

    def checkpoint(self, step: int) -> None:
        """Replace the checkpoint with the engine state at ``step`` (covering the committed
        frames), then record the status."""
        state = self.sim.to_checkpoint()
        need = sum(np.asarray(v).nbytes for v in state.values()) + SPACE_MARGIN
        ensure_free_space(self.rd.checkpoint, need, "the checkpoint")
        self.rd.save_checkpoint(state, {"frames": self.written, "fingerprint": self.fingerprint,
                                        "run_id": self.spec.run_id, "step": step},
                                before_replace=lambda _tmp: faults().kill("checkpoint-write"))
        faults().kill("checkpoint")
        self.record(step)

    def stop_at(self, step: int) -> None:
        """Commit what is buffered and checkpoint at ``step`` (a stop was requested)."""
        if self.buffer:
            self.commit()
        self.checkpoint(step)

    def settle(self, step: int) -> bool:
        """The ``run.until`` check at a check step (frames up to ``step`` committed);
        ``False`` without a check there."""
        until, steps = self.cfg.run.until, self.cfg.run.steps
        if until is None or not until.is_check_step(step, steps) or self.buffer:
            return False
        c = time.process_time()
        verdict = _assess(self.rd.partial, self.cfg)
        self.cost["check_cpu_seconds"] += time.process_time() - c
        self.last_check = {"step": int(step), "settled": verdict.settled, "unmet": list(verdict.unmet),
                           **{k: (None if not np.isfinite(v) else round(float(v), 6))
                              for k, v in verdict.values.items()}}
        self.record(step)
        return verdict.settled

    def finalize(self, stop_reason: str) -> int:
        """Mark the partial trajectory complete, promote it to ``trajectory.h5`` and write
        status ``done``; returns the steps done."""
        cfg = self.cfg
        done = int(self.sim.state.step)
        projections = int(self.sim.state.projections)
        partial = self.rd.partial
        set_attrs(partial, schema.PARAMETERS, {
            "complete": 1, "finished": now_iso(), "projections_final": projections, "stop_reason": stop_reason,
            "steps_done": done, "steps": cfg.run.steps, "checkpoint_every": cfg.run.checkpoint_every,
            "transient": cfg.run.transient, "until_json": until_meta(cfg), "fingerprint": self.fingerprint,
            "config_json": json.dumps(cfg.to_dict(), sort_keys=True)})
        ensure_free_space(self.rd.path, partial.stat().st_size + SPACE_MARGIN, "repacking the finished trajectory")
        self.rd.promote_partial()
        faults().kill("finalize")
        self.rd.mark_done(reason=self.reason, steps_done=done, projections=projections, stop_reason=stop_reason,
                          **self.costs(done), **({"check": self.last_check} if self.last_check else {}))
        return done
