"""A sweep directory ``<output>/``: where its files are, and what state each run is in.

One place for what every command reads of a sweep directory:

- paths: :func:`run_path` (``<output>/runs/<run_id>``), the file names of
  :mod:`fcsweep.io.schema`;
- :func:`atomic_write`: the temporary-file-and-rename write behind ``status.json``,
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

import contextlib
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

from fcsweep.io import failures, schema
from fcsweep.io.locks import DEFAULT_STALE_AFTER, lock_info, lock_is_stale
from fcsweep.io.failures import WriteFailure
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


def atomic_write(path, writer: Callable[[Path], None], *, fsync: bool = False,
                 before_replace: Callable[[Path], None] | None = None, suffix: str = "",
                 interruptible: bool = False) -> Path:
    """Write ``path`` through a temporary file beside it and :func:`os.replace`: the one
    write path of every file a reader may open while it is written (status, checkpoints,
    trajectories, analyses, datasets, figures, movies, exports, the cost cache).

    A reader sees the previous file or the complete new one.  On EVERY error, including
    ``KeyboardInterrupt`` and ``SystemExit`` (a signal), the temporary file is removed and
    the previous file is left as it was; a failure of the environment (full disk, quota,
    read-only or forbidden directory) is raised as
    :class:`fcsweep.io.failures.WriteFailure` naming ``path``.  Only SIGKILL (or a power
    cut) can leave the temporary file, which :func:`fcsweep.io.failures.remove_stale`
    removes.

    On NFS / Lustre / GPFS the rename is atomic on the server too (a reader holding the
    old file open keeps reading it; NFS may show it as ``.nfsXXXX`` until closed, which
    the server removes); the directory fsync is what makes the rename durable where the
    file system supports it and is skipped where it does not.

    Parameters
    ----------
    path : path-like
        Destination.
    writer : callable
        ``writer(tmp)`` writes the whole file at the temporary path
        ``.<name>.<pid>.tmp<suffix>``.
    fsync : bool
        fsync the temporary file before the rename and the directory after it.
    before_replace : callable, optional
        Called with the temporary path just before the rename (test hook for kills).
    suffix : str
        Extension of the temporary name, for libraries that pick the format by it
        (``".mp4"`` for ffmpeg).
    interruptible : bool
        Let SIGINT / SIGTERM interrupt ``writer`` (long writes: exports, movies); by
        default they are held until the file is written and renamed
        (:func:`fcsweep.io.failures.signals_held`), then handled.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    fcsweep.io.failures.WriteFailure
        For a failure of the environment; other errors are raised as they are.
    """
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp{suffix}")
    held = contextlib.nullcontext() if interruptible else failures.signals_held()
    with held:
        _write_and_rename(path, tmp, writer, fsync, before_replace)
    failures.count_write()
    failures.kill_point(path, "after-rename")
    if fsync:
        fsync_dir(path.parent)
    return path


def _write_and_rename(path: Path, tmp: Path, writer, fsync: bool, before_replace) -> None:
    try:
        try:
            writer(tmp)
            failures.injected_error(path)
            failures.kill_point(path, "written")
            if fsync:
                fd = os.open(tmp, os.O_RDONLY)
                try:
                    os.fsync(fd)
                finally:
                    os.close(fd)
            if before_replace is not None:
                before_replace(tmp)
            failures.kill_point(path, "before-rename")
            os.replace(tmp, path)
        except BaseException as exc:
            why = failures.classify(exc, path, free_at=tmp)
            if why is not None:
                raise why from exc
            raise
    except BaseException:
        try:
            tmp.unlink()
        except OSError:
            pass
        raise


def fsync_dir(path) -> None:
    """fsync a directory so a rename inside it is durable (no-op where unsupported)."""
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:  # pragma: no cover
        return
    try:
        os.fsync(fd)
    except OSError:  # pragma: no cover - e.g. some network file systems
        pass
    finally:
        os.close(fd)


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
    from fcsweep.io.refinement import read_points

    return tuple(read_points(output))
