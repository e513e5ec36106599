"""When a results file cannot be written: what the cause was, one line for the user, and
the test hooks that make such failures and kills happen on purpose.

Every results writer goes through :func:`fcsweep.io.sweepdir.atomic_write`, which turns a
failure of the environment (full disk, quota, read-only or forbidden directory) into a
:class:`WriteFailure` naming the file, after removing its temporary file.  Libraries do not
always say ``errno``: h5py words a full disk as "Can't close file (file write failed: ...
errno = 28 ...)", netCDF4 only as "NetCDF: HDF error".  :func:`classify` reads the errno
where there is one (attribute or text) and otherwise asks the file system: with less than
:data:`LOW_SPACE` bytes free beside the temporary file when the write failed, the cause was
the lack of space.  So it is for "permission denied", which netCDF4 also says when it cannot
create a file on a full disk.

Signals: :func:`results_command` wraps the work of ``analyze``, ``aggregate``, ``plot``,
``movie`` and ``export`` (SIGTERM raises :class:`Terminated` like SIGINT raises
``KeyboardInterrupt``; one line and exit 130 / 143); :func:`signals_held` keeps both out of
short writes, which finish and are renamed first; :func:`run_main` gives the same exit
codes to a signal that comes while a command loads.  SIGKILL leaves at most one temporary
file per writer, which :func:`remove_stale` removes on the next command.

The faults that tests make on purpose (kills at the points of a write, injected errors) are
:mod:`fcsweep.io.faults`.
"""

from __future__ import annotations

import errno as _errno
import fnmatch
import os
import re
import shutil
import signal
import threading
from contextlib import contextmanager
from pathlib import Path

from fcsweep.io.faults import faults

__all__ = ["WriteFailure", "classify", "remove_stale", "advice",
           "ENVIRONMENT_ERRNOS", "LOW_SPACE", "written_count", "count_write", "Terminated", "sigterm_raises",
           "probe_writable", "results_command", "signals_held", "run_main"]

#: errno values that are failures of the environment, with the word shown for each.
ENVIRONMENT_ERRNOS = {
    _errno.ENOSPC: "no space left on device",
    _errno.EDQUOT: "disk quota exceeded",
    _errno.EROFS: "read-only file system",
    _errno.EACCES: "permission denied",
    _errno.EPERM: "operation not permitted",
}
#: Free bytes below which a write failure without errno is taken for a full disk.
LOW_SPACE = 1 << 20
_TMP_NAME = re.compile(r"^\.(?P<name>.+)\.(?P<pid>\d+)\.tmp(\.\w+)?$")
_ERRNO_TEXT = re.compile(r"errno\s*=\s*(\d+)|\[Errno (\d+)\]")
_written = [0]


class WriteFailure(OSError):
    """A results file could not be written for a reason of the environment.

    ``errno`` is one of :data:`ENVIRONMENT_ERRNOS`, ``filename`` the file that was to be
    written, ``strerror`` the cause in words.  The previous file, if any, is untouched and
    no temporary file is left.
    """

    @property
    def space(self) -> bool:
        """The cause is the lack of space (disk or quota)."""
        return self.errno in (_errno.ENOSPC, _errno.EDQUOT)


def _errno_of(exc: BaseException) -> int | None:
    for e in (exc, exc.__cause__, exc.__context__):
        if isinstance(e, OSError) and e.errno in ENVIRONMENT_ERRNOS:
            return e.errno
        if e is not None:
            m = _ERRNO_TEXT.search(str(e))
            if m and int(m.group(1) or m.group(2)) in ENVIRONMENT_ERRNOS:
                return int(m.group(1) or m.group(2))
    return None


def classify(exc: BaseException, path, free_at=None) -> WriteFailure | None:
    """The :class:`WriteFailure` that ``exc`` (raised while writing ``path``) stands for, or
    ``None`` when it is no failure of the environment (a bug, bad data, an interrupt).

    ``free_at`` is a path on the same file system whose free space is asked when the
    exception carries no errno (the temporary file, before it is removed).
    """
    if isinstance(exc, WriteFailure):
        return exc
    if not isinstance(exc, Exception):
        return None
    code = _errno_of(exc)
    # netCDF4 says PermissionError (EACCES) when it cannot create a file on a full disk
    if code in (None, _errno.EACCES, _errno.EPERM) and free_at is not None:
        try:
            if shutil.disk_usage(Path(free_at).parent).free < LOW_SPACE:
                code = _errno.ENOSPC
        except OSError:
            pass
    if code is None:
        return None
    return WriteFailure(code, ENVIRONMENT_ERRNOS[code], str(path))


def count_write() -> None:
    """Count one completed atomic write of this process (see :func:`written_count`)."""
    _written[0] += 1


def written_count() -> int:
    """Atomic writes completed by this process so far: a command compares it before and
    after to tell "nothing was written" (exit 2) from "part of it was" (exit 1)."""
    return _written[0]


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # e.g. EPERM: someone else's live process
        return True
    return True


def remove_stale(directory, names=("*",)) -> list[Path]:
    """Remove the temporary files ``.<name>.<pid>.tmp[.ext]`` of :func:`atomic_write` in
    ``directory`` whose writer process is gone (killed, e.g. by SIGKILL), for destination
    names matching one of the globs ``names``; returns what was removed.

    A writer is looked for by its process id on this machine; on a file system shared by
    several machines a live writer elsewhere may share a dead local pid, so commands only
    clean the directories they are about to write themselves.
    """
    out = []
    d = Path(directory)
    if not d.is_dir():
        return out
    for tmp in d.glob(".*.tmp*"):
        m = _TMP_NAME.match(tmp.name)
        if m is None or not any(fnmatch.fnmatch(m["name"], n) for n in names):
            continue
        if int(m["pid"]) != os.getpid() and not _alive(int(m["pid"])):
            try:
                tmp.unlink()
                out.append(tmp)
            except OSError:
                pass
    return out


def advice(exc: WriteFailure, where: str = "") -> str:
    """One line for the user: the file, the cause and what to do.

    ``where`` names the option that sends the output elsewhere (``--out``, ``--outdir``),
    or is empty for results that belong in the sweep directory.
    """
    what = f"cannot write {exc.filename}: {exc.strerror}"
    if exc.space:
        todo = "free space there" + (f" or give {where} on another file system" if where else "")
    elif where:
        todo = f"give {where} a writable directory"
    else:
        todo = "this command writes into the sweep directory: run it on a writable copy, or where it can be written"
    return f"{what}; {todo}"


class Terminated(BaseException):
    """SIGTERM, raised where the process is (as ``KeyboardInterrupt`` is for SIGINT) so that
    every ``finally`` and :func:`atomic_write`'s cleanup runs; exit status 143."""


def _raise_terminated(signum, frame):
    raise Terminated()


@contextmanager
def sigterm_raises():
    """Within the block SIGTERM raises :class:`Terminated` (results commands: a write
    being made is abandoned cleanly, earlier results stay); the previous handler after."""
    try:
        old = signal.signal(signal.SIGTERM, _raise_terminated)
    except ValueError:  # not the main thread
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, old)


def probe_writable(directory) -> None:
    """Raise :class:`WriteFailure` (naming ``directory``) unless a file can be created in
    it: a read-only sweep is refused before any work, rather than after it."""
    d = Path(directory)
    probe = d / f".fcsweep-write-probe.{os.getpid()}.tmp"
    try:
        faults().write_error(probe)
        probe.touch()
        probe.unlink()
    except OSError as exc:  # another errno (the directory is gone): the command reports that itself
        if exc.errno in ENVIRONMENT_ERRNOS:
            raise WriteFailure(exc.errno, ENVIRONMENT_ERRNOS[exc.errno], str(d)) from None


@contextmanager
def results_command(say, where: str = ""):
    """Run a results command (analyze, aggregate, plot, movie, export): SIGTERM raises
    :class:`Terminated`; a :class:`WriteFailure` becomes one line (:func:`advice`) and exit
    2 when this process completed no write, else 1; SIGINT exits 130 and SIGTERM 143, each
    with one line.  Whatever ends the block, every earlier result is intact and the
    temporary file of the write under way is removed by :func:`atomic_write`."""
    start = written_count()
    with sigterm_raises():
        try:
            yield
        except WriteFailure as exc:
            say(advice(exc, where))
            raise SystemExit(1 if written_count() > start else 2) from None
        except (KeyboardInterrupt, Terminated) as exc:
            name, code = ("SIGINT", 130) if isinstance(exc, KeyboardInterrupt) else ("SIGTERM", 143)
            say(f"stopped by {name}; every result written before is intact, no temporary file is left")
            raise SystemExit(code) from None


@contextmanager
def signals_held():
    """Within the block SIGINT and SIGTERM are held, and given to the handlers they had
    (raising, flag-setting or default) when it ends.

    An exception raised by a signal handler can land between a lock's acquire and the
    ``try`` that releases it (xarray's and netCDF4's file locks, for one): the cleanup that
    follows then waits for that lock forever.  Short writes hold the signals instead
    (:func:`fcsweep.io.sweepdir.atomic_write`); outside the main thread nothing is held.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    got: list[int] = []
    old = {sig: signal.signal(sig, lambda signum, frame: got.append(signum)) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for sig, handler in old.items():
            signal.signal(sig, handler)
        for sig in dict.fromkeys(got):
            if callable(old[sig]):
                old[sig](sig, None)
            elif old[sig] == signal.SIG_DFL:
                signal.raise_signal(sig)


def run_main(group, prog_name: str, say) -> None:
    """Run the click ``group`` as a program: SIGINT / SIGTERM that arrive before a command
    set its own handling (while it loads) exit 130 / 143 with one line, as they do after
    (click alone would print "Aborted!" and exit 1, or die by the signal)."""
    import click

    try:
        with sigterm_raises():
            code = group.main(prog_name=prog_name, standalone_mode=False)
    except click.exceptions.Abort as exc:
        stopped = isinstance(exc.__cause__, KeyboardInterrupt)
        say("stopped by SIGINT" if stopped else "aborted")
        raise SystemExit(130 if stopped else 1) from None
    except Terminated:
        say("stopped by SIGTERM")
        raise SystemExit(143) from None
    except click.ClickException as exc:
        exc.show()
        raise SystemExit(exc.exit_code) from None
    raise SystemExit(code if isinstance(code, int) else 0)
