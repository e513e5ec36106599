"""The one write path of every file a reader may open while it is written:
:func:`atomic_write` (a temporary file beside the destination, then :func:`os.replace`)
and :func:`fsync_dir`.  It sits below every other module of :mod:`fcsweep.io` that
writes (status, refinement, checkpoints, run directories); :mod:`fcsweep.io.sweepdir`
re-exports both names.
"""

from __future__ import annotations

import contextlib
import os
from pathlib import Path
from typing import Callable

from fcsweep.io import failures
from fcsweep.io.faults import faults

__all__ = ["atomic_write", "fsync_dir"]


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
    faults().kill("after-rename", path)
    if fsync:
        fsync_dir(path.parent)
    return path


def _write_and_rename(path: Path, tmp: Path, writer, fsync: bool, before_replace) -> None:
    try:
        try:
            writer(tmp)
            made = faults()
            made.write_error(path)
            made.kill("written", path)
            if fsync:
                fd = os.open(tmp, os.O_RDONLY)
                try:
                    os.fsync(fd)
                finally:
                    os.close(fd)
            if before_replace is not None:
                before_replace(tmp)
            made.kill("before-rename", path)
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
