"""One run directory ``<output>/runs/<run_id>/``: its files, its lock and its state.

:class:`RunDirectory` owns the transitions of a run's ``status.json``::

    pending -> running -> done
                 |-> interrupted   (signal: checkpoint written at the current step)
                 |-> failed        (cause "simulation": final until --retry-failed;
                 |                  cause "io": disk full, quota, EIO, read-only --
                 |                  the next launch resumes from the last checkpoint)
    done -> corrupt                (the trajectory fails its checksums or is gone; recomputed)

so that the sweep runner handles each fault in one place.  Writes of the failure states
are best effort: a full disk may refuse even ``status.json``, and the run's lock is
released whatever happens (the state then reads ``interrupted``, which resumes too).

It also owns every move of the run's files: the checkpoint replaced atomically
(:meth:`RunDirectory.save_checkpoint`), ``trajectory.h5.partial`` promoted to
``trajectory.h5`` when the run ends (:meth:`~RunDirectory.promote_partial`) and a finished
trajectory turned back into a partial one to be extended (:meth:`~RunDirectory.reopen`),
and the removals (temporaries of killed writers, a restart from step 0, a stale analysis).
"""

from __future__ import annotations

import errno
import json
import os
import re
import shutil
import socket
import time
from pathlib import Path
from typing import Any, Callable, Mapping

from fcsweep.io import schema
from fcsweep.io.checkpoint import META_PREFIX, load_checkpoint, save_checkpoint, split_meta
from fcsweep.io.h5md import repack, seq_path, set_attrs, verify_trajectory
from fcsweep.io.locks import DEFAULT_STALE_AFTER, RunLock, lock_info, lock_is_stale
from fcsweep.io.status import read_status, write_status
from fcsweep.io.sweepdir import atomic_write, fsync_dir, run_state

__all__ = ["RunDirectory", "io_error_cause", "free_bytes", "ensure_free_space", "now_iso"]

#: errno -> what an operator should read.
_IO_ERRNOS = {
    errno.ENOSPC: "no space left on device",
    errno.EDQUOT: "disk quota exceeded",
    errno.EIO: "input/output error",
    errno.EROFS: "read-only file system",
    errno.EACCES: "permission denied",
    errno.EPERM: "operation not permitted",
    errno.EFBIG: "file too large",
    errno.ESTALE: "stale NFS file handle",
}
_ERRNO_IN_TEXT = re.compile(r"errno = (\d+)|\[Errno (\d+)\]")


def now_iso() -> str:
    """Local time stamp as written into status files."""
    return time.strftime("%Y-%m-%dT%H:%M:%S%z")


def io_error_cause(exc: BaseException) -> str | None:
    """``"no space left on device (path)"`` etc. if ``exc`` is an environmental I/O error.

    Recognises ``OSError.errno`` and the ``errno = N`` that HDF5 puts into h5py's
    messages; ``None`` for anything else (a bug or a simulation failure).
    """
    if not isinstance(exc, OSError):
        return None
    code = exc.errno
    if code is None:
        m = _ERRNO_IN_TEXT.search(str(exc))
        if m:
            code = int(m.group(1) or m.group(2))
    if code not in _IO_ERRNOS:
        return None
    where = f" ({exc.filename})" if getattr(exc, "filename", None) else ""
    return f"{_IO_ERRNOS[code]}{where}"


def free_bytes(path) -> int:
    """Bytes available to this user on the file system holding ``path`` (or its nearest
    existing ancestor)."""
    p = Path(path).absolute()
    while not p.exists() and p.parent != p:
        p = p.parent
    return int(shutil.disk_usage(p).free)


def ensure_free_space(path, need: int, what: str) -> None:
    """Raise ``OSError(ENOSPC)`` *before* writing ``need`` bytes that would not fit.

    HDF5 does not always fail cleanly when a write hits a full disk (it can leave a file
    that cannot be reopened for writing, or crash), so writers check first.
    """
    free = free_bytes(path)
    if free < need:
        raise OSError(errno.ENOSPC, f"No space left on device: {what} needs {need / 2**20:.1f} MiB, "
                                    f"{free / 2**20:.1f} MiB free", str(path))


class RunDirectory:
    """Files, lock and state of one run.

    Parameters
    ----------
    path : path-like
        ``<output>/runs/<run_id>``.
    run_id : str
    index : int
        Position of the run in its sweep.
    params : mapping, optional
        Model parameters, recorded in ``status.json``.
    """

    def __init__(self, path, run_id: str, index: int, params: dict | None = None):
        self.path = Path(path)
        self.run_id = run_id
        self.index = int(index)
        self.params = dict(params or {})
        self.trajectory = self.path / schema.TRAJECTORY
        self.partial = self.path / schema.TRAJECTORY_PARTIAL
        self.checkpoint = self.path / schema.CHECKPOINT
        self.lock_path = self.path / schema.LOCK
        self.lock: RunLock | None = None
        self._base: dict[str, Any] = {}

    # ------------------------------------------------------------------ reading

    def status(self) -> dict[str, Any]:
        """``status.json`` (``{}`` if none or unreadable)."""
        return read_status(self.path) or {}

    def live_lock(self, stale_after: float = DEFAULT_STALE_AFTER) -> dict[str, Any] | None:
        """The lock's contents if a live process holds it (fresh heartbeat), else ``None``."""
        info = lock_info(self.lock_path)
        return info if info is not None and not lock_is_stale(info, stale_after) else None

    def state(self, stale_after: float = DEFAULT_STALE_AFTER) -> str:
        """The state a reader should show (:func:`fcsweep.io.sweepdir.run_state`): the
        status word, with ``running`` only while a live lock backs it (else
        ``interrupted``) and ``done`` only with a trajectory (else ``corrupt``)."""
        return run_state(self.path, stale_after).state

    def committed_frames(self) -> int:
        """Frames of a running run that a live reader may use: those the last checkpoint
        covers (later frames of ``trajectory.h5.partial`` may be mid-append)."""
        ck = load_checkpoint(self.checkpoint, keys=[META_PREFIX + "frames"])  # not the engine state
        if ck is None:
            return 0
        return int(split_meta(ck)[1].get("frames", 0))

    def verify(self, n_frames: int | None = None) -> str | None:
        """Problem with the finished trajectory (see :func:`verify_trajectory`), or ``None``."""
        if not self.trajectory.exists():
            return "trajectory.h5 is missing"
        return verify_trajectory(self.trajectory, n_frames)

    def unchanged_since_done(self) -> bool:
        """Whether trajectory.h5 has the size and mtime recorded when the run finished
        (a cheap test; :meth:`verify` reads every checksum)."""
        rec = self.status().get("trajectory")
        try:
            st = self.trajectory.stat()
        except OSError:
            return False
        return isinstance(rec, dict) and rec.get("bytes") == st.st_size and rec.get("mtime_ns") == st.st_mtime_ns

    # ------------------------------------------------------------------ locking

    def acquire(self, stale_after: float = DEFAULT_STALE_AFTER) -> bool:
        """Take the run's lock (and start its heartbeat); ``False`` if a live process holds it."""
        self.lock = RunLock(self.lock_path, stale_after=stale_after)
        if not self.lock.acquire():
            return False
        self.lock.start_heartbeat()
        return True

    def held_by(self) -> str:
        h = (self.lock.held_by if self.lock else None) or {}
        return f"held by pid {h.get('pid')} on {h.get('host')} since {h.get('started')}"

    def release(self) -> None:
        """Release the lock (never raises)."""
        if self.lock is not None:
            try:
                self.lock.release()
            except OSError:  # pragma: no cover - e.g. the file system went away
                pass

    # -------------------------------------------------------------------- files

    def remove_temporaries(self) -> None:
        """Remove the ``.<name>.<pid>.tmp`` files that killed writers left behind."""
        for tmp in self.path.glob(".*.tmp"):
            try:
                tmp.unlink()
            except OSError:
                pass

    def remove_analysis(self) -> None:
        """Remove ``analysis.h5`` and its error file (they describe another trajectory)."""
        for name in (schema.ANALYSIS, schema.ANALYSIS_ERROR):
            (self.path / name).unlink(missing_ok=True)

    def remove_trajectory(self, *, analysis: bool = True) -> None:
        """Remove ``trajectory.h5`` (if there is one) and, if ``analysis``, its analysis."""
        self.trajectory.unlink(missing_ok=True)
        if analysis:
            self.remove_analysis()

    def remove_partial(self) -> None:
        """Remove ``trajectory.h5.partial`` (a finished trajectory supersedes it)."""
        self.partial.unlink(missing_ok=True)

    def start_over(self) -> None:
        """Remove the partial trajectory and the checkpoint: the run restarts from step 0."""
        self.partial.unlink(missing_ok=True)
        self.checkpoint.unlink(missing_ok=True)

    def save_checkpoint(self, state: Mapping[str, Any], meta: Mapping[str, Any], *,
                        before_replace: Callable[[Path], None] | None = None) -> None:
        """Replace ``checkpoint.npz`` atomically (:func:`fcsweep.io.checkpoint.save_checkpoint`)."""
        save_checkpoint(self.checkpoint, state, meta, before_replace=before_replace)

    def promote_partial(self) -> None:
        """Finish the trajectory: ``trajectory.h5.partial`` (already marked complete) is
        repacked into a fresh file that replaces ``trajectory.h5`` atomically, then the
        partial file and its write counter are removed."""
        atomic_write(self.trajectory, lambda tmp: repack(self.partial, tmp))
        self.partial.unlink()
        seq_path(self.partial).unlink(missing_ok=True)  # live readers' write counter (io.h5md)
        fsync_dir(self.path)

    def reopen(self) -> None:
        """Turn the finished ``trajectory.h5`` back into ``trajectory.h5.partial`` (marked
        not complete) to be extended; the analysis of the shorter run is removed."""
        def write(tmp: Path) -> None:
            repack(self.trajectory, tmp)
            set_attrs(tmp, schema.PARAMETERS, {"complete": 0, "stop_reason": ""})
            seq_path(tmp).unlink(missing_ok=True)  # set_attrs's write counter would outlive the rename

        atomic_write(self.partial, write)
        fsync_dir(self.path)
        self.remove_analysis()
        self.trajectory.unlink()

    # -------------------------------------------------------------- transitions

    def begin(self, base: dict[str, Any]) -> None:
        """Remember fields written with every later status (steps, fingerprint, attempts...)."""
        self._base = dict(base)

    def _write(self, status: str, *, best_effort: bool = False, **fields: Any) -> bool:
        data = {
            **self._base,
            "status": status,
            "run_id": self.run_id,
            "index": self.index,
            "params": self.params,
            "host": socket.gethostname(),
            "pid": os.getpid(),
            "updated": now_iso(),
            **fields,
        }
        try:
            write_status(self.path, data)
        except OSError:
            if not best_effort:
                raise
            return False
        return True

    def mark_running(self, **fields: Any) -> None:
        """Progress of a computing run (``steps_done``, ``projections``, ``wall_seconds``...)."""
        self._write(schema.RUNNING, reason=fields.pop("reason", ""), **fields)

    def mark_done(self, **fields: Any) -> None:
        """Finished: records the trajectory's size and mtime for :meth:`unchanged_since_done`."""
        st = self.trajectory.stat()
        self._write(schema.DONE, reason=fields.pop("reason", ""),
                    trajectory={"bytes": st.st_size, "mtime_ns": st.st_mtime_ns}, **fields)

    def mark_interrupted(self, signal_name: str, step: int, **fields: Any) -> bool:
        """Stopped by a signal with a checkpoint at ``step`` (best effort)."""
        return self._write(schema.INTERRUPTED, best_effort=True, reason=f"{signal_name} at step {step}",
                           signal=signal_name, checkpoint_step=int(step), **fields)

    def mark_failed(self, reason: str, cause: str, **fields: Any) -> bool:
        """Failed; ``cause`` is ``schema.CAUSE_IO`` (retried by the next launch) or
        ``schema.CAUSE_SIMULATION`` (not retried without
        ``--retry-failed``).  ``stop_reason`` becomes "failed"; steps done and cost are kept.
        Best effort."""
        prev = self.status()
        keep = {k: prev[k] for k in ("steps_done", "projections", *schema.COST_KEYS) if k in prev}
        return self._write(schema.FAILED, best_effort=True, reason=reason, cause=cause, stop_reason="failed",
                           **{**keep, **fields})

    def mark_corrupt(self, problem: str) -> bool:
        """A done run whose trajectory fails verification (best effort)."""
        prev = self.status()
        return self._write(schema.CORRUPT, best_effort=True, reason=f"trajectory.h5 damaged: {problem}",
                           steps_done=0, steps=prev.get("steps"), fingerprint=prev.get("fingerprint"),
                           attempts=prev.get("attempts", 1),
                           **{k: prev[k] for k in schema.COST_KEYS if k in prev})


def analysis_is_current(analysis, trajectory=None, *, settings: Mapping[str, Any] | None = None,
                        transient: float | None = None) -> bool:
    """Whether the analysis file ``analysis`` is up to date: the one rule of
    ``fcsweep status`` (analysed ``yes`` / ``stale``) and of ``fcsweep analyze`` (skip or
    recompute).

    It is current when it exists and can be read, was made with the current label rules
    (``schema.LABEL_RULES``), is not older than ``trajectory`` (when given and present),
    and was made with ``settings`` (when given: equal dicts) or
    else, when ``transient`` is given, with that transient (a file that records none
    counts as made with it).

    Parameters
    ----------
    analysis : path-like
        ``analysis.h5``.
    trajectory : path-like, optional
        The trajectory it describes; a newer trajectory makes it stale.
    settings : mapping, optional
        The analysis settings that would be used now.
    transient : float, optional
        Compared when ``settings`` is not given.

    Returns
    -------
    bool
        ``False`` also for a missing or unreadable file (it is recomputed).
    """
    import h5py

    analysis = Path(analysis)
    try:
        if trajectory is not None and Path(trajectory).exists() and \
                Path(trajectory).stat().st_mtime > analysis.stat().st_mtime:
            return False
        with h5py.File(analysis, "r", locking=False) as f:
            used = json.loads(f.attrs.get(schema.ANALYSIS_SETTINGS_ATTR, "{}"))
            rules = int(f.attrs.get(schema.LABEL_RULES_ATTR, 0))
    except (OSError, ValueError):
        return False
    if rules != schema.LABEL_RULES:
        return False
    if settings is not None:
        return used == dict(settings)
    t = used.get("transient") if transient is not None else None
    return t is None or abs(float(t) - float(transient)) <= 1e-12

