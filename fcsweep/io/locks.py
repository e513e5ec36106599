"""Per-run lock files that work on local and network file systems.

A lock is a small JSON file (``run.lock``) created with ``O_CREAT | O_EXCL`` (atomic on
POSIX file systems and on NFSv3+), holding ``pid``, ``host``, ``started`` and a random
``token``.  The holder refreshes the file's mtime every :data:`HEARTBEAT` seconds from a
daemon thread (:meth:`RunLock.start_heartbeat`) while it works.

A lock is *stale*, and may be taken over, when

* its host is this host and its pid no longer exists (a killed process), or
* its heartbeat (mtime) is older than ``stale_after`` seconds (default four heartbeat
  periods, 60 s; environment variable ``FCSWEEP_LOCK_STALE_SECONDS``): the test that works
  across hosts, since a pid on another node cannot be checked; it also covers a reused pid
  on this host.  The age is measured against the *file system's* clock (the mtime of a
  probe file written beside the lock), so clock skew between nodes and the file server
  does not make live locks look stale or dead ones look live.

Taking over is serialised by a second short-lived ``O_EXCL`` file (``run.lock.break``) so
that two processes that both find the same stale lock cannot both win, and a process never
removes a lock other than the one it judged stale (the token is compared again).
"""

from __future__ import annotations

import json
import os
import secrets
import socket
import threading
import time
from pathlib import Path
from typing import Any

__all__ = [
    "RunLock", "LockHeld", "LockLost", "lock_info", "lock_is_stale", "pid_alive", "fs_now",
    "DEFAULT_STALE_AFTER", "HEARTBEAT",
]

#: Seconds between heartbeats of a held lock.
HEARTBEAT = 15.0
DEFAULT_STALE_AFTER = float(os.environ.get("FCSWEEP_LOCK_STALE_SECONDS", 4 * HEARTBEAT))
_BREAK_STALE_AFTER = 60.0
_FS_CLOCK: dict[int, tuple[float, float]] = {}  # st_dev -> (fs time - local time, local time measured)
_FS_CLOCK_TTL = 30.0


def fs_now(directory) -> float:
    """Current time on the clock of the file system holding ``directory``.

    The offset to the local clock is measured by creating a probe file there and reading
    its mtime (set by the file server on network file systems), cached per device for
    30 s.  Falls back to the local clock where the directory cannot be written.
    """
    directory = Path(directory)
    now = time.time()
    try:
        dev = directory.stat().st_dev
    except OSError:
        return now
    cached = _FS_CLOCK.get(dev)
    if cached is not None and now - cached[1] < _FS_CLOCK_TTL:
        return now + cached[0]
    probe = directory / f".fcsweep-clock.{socket.gethostname()}.{os.getpid()}.{secrets.token_hex(4)}"
    try:
        fd = os.open(probe, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
        try:
            mtime = os.fstat(fd).st_mtime
        finally:
            os.close(fd)
            os.unlink(probe)
    except OSError:
        return now
    offset = mtime - now
    # a local file system: same clock (sub-second differences are timestamp granularity)
    offset = 0.0 if abs(offset) < 1.0 else offset
    _FS_CLOCK[dev] = (offset, now)
    return now + offset


class LockHeld(RuntimeError):
    """The run is locked by another live process."""

    def __init__(self, path, info: dict[str, Any] | None):
        self.info = info or {}
        who = f"pid {self.info.get('pid')} on {self.info.get('host')}" if info else "another process"
        super().__init__(f"{path} is held by {who} since {self.info.get('started', '?')}")


class LockLost(RuntimeError):
    """Our lock was taken over (e.g. our heartbeat stalled past ``stale_after``)."""


def pid_alive(pid: int) -> bool:
    """Whether a process with this pid exists on this host."""
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def lock_info(path) -> dict[str, Any] | None:
    """Contents of a lock file plus its heartbeat age, or ``None`` if absent/unreadable."""
    path = Path(path)
    try:
        st = path.stat()
        with open(path) as fh:
            info = json.load(fh)
    except (OSError, ValueError):
        try:
            st = path.stat()
        except OSError:
            return None
        # Present but empty/garbled: the creator died between create and write.
        return {"pid": -1, "host": "?", "token": None, "age": fs_now(path.parent) - st.st_mtime, "garbled": True}
    if not isinstance(info, dict):
        info = {}
    info["age"] = fs_now(path.parent) - st.st_mtime
    return info


def lock_is_stale(info: dict[str, Any] | None, stale_after: float = DEFAULT_STALE_AFTER) -> bool:
    """Whether a lock (as returned by :func:`lock_info`) may be taken over."""
    if info is None:
        return True
    if info.get("garbled"):
        return info["age"] > 5.0
    if info.get("host") == socket.gethostname():
        if not pid_alive(int(info.get("pid", -1))):
            return True
    return info["age"] > stale_after


class RunLock:
    """Exclusive lock of one run directory.

    Examples
    --------
    >>> lock = RunLock(run_dir / "run.lock")       # doctest: +SKIP
    >>> if lock.acquire():                          # doctest: +SKIP
    ...     try: work(); lock.heartbeat()
    ...     finally: lock.release()
    """

    def __init__(self, path, stale_after: float = DEFAULT_STALE_AFTER):
        self.path = Path(path)
        self.stale_after = float(stale_after)
        self.token: str | None = None
        self.held_by: dict[str, Any] | None = None
        self.took_over: dict[str, Any] | None = None
        self._last_beat = 0.0
        self._stop: threading.Event | None = None

    def _create(self) -> bool:
        token = secrets.token_hex(8)
        try:
            fd = os.open(self.path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
        except FileExistsError:
            return False
        info = {
            "pid": os.getpid(),
            "host": socket.gethostname(),
            "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
            "token": token,
        }
        with os.fdopen(fd, "w") as fh:
            json.dump(info, fh)
            fh.flush()
            os.fsync(fh.fileno())
        self.token = token
        self._last_beat = time.time()
        return True

    def _break_stale(self, seen: dict[str, Any]) -> None:
        brk = self.path.with_name(self.path.name + ".break")
        try:
            fd = os.open(brk, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
        except FileExistsError:
            try:
                if time.time() - brk.stat().st_mtime > _BREAK_STALE_AFTER:
                    brk.unlink()
            except OSError:
                pass
            return
        os.close(fd)
        try:
            now = lock_info(self.path)
            if now is not None and now.get("token") == seen.get("token") and lock_is_stale(now, self.stale_after):
                self.path.unlink()
                self.took_over = seen
        except OSError:
            pass
        finally:
            try:
                brk.unlink()
            except OSError:
                pass

    def acquire(self) -> bool:
        """Try to take the lock (taking over a stale one); ``False`` if a live process holds it."""
        for _ in range(5):
            if self._create():
                return True
            info = lock_info(self.path)
            if info is None:
                continue  # vanished in between: try again
            if not lock_is_stale(info, self.stale_after):
                self.held_by = info
                return False
            self._break_stale(info)
        info = lock_info(self.path)
        self.held_by = info
        return False

    def heartbeat(self, min_interval: float = HEARTBEAT) -> None:
        """Refresh the lock's mtime (at most every ``min_interval`` seconds)."""
        now = time.time()
        if self.token is None or now - self._last_beat < min_interval:
            return
        try:
            os.utime(self.path)
        except OSError:
            pass
        self._last_beat = now

    def start_heartbeat(self, interval: float | None = None) -> None:
        """Refresh the mtime every ``interval`` s from a daemon thread (until release).

        Default: :data:`HEARTBEAT`, or a quarter of ``stale_after`` if that is shorter, so
        that a live holder never looks stale.  The engine's kernels return to Python every
        few hundred steps, so the thread runs even while a long ``advance`` call is in
        progress.
        """
        if self.token is None or self._stop is not None:
            return
        if interval is None:
            interval = min(HEARTBEAT, self.stale_after / 4.0)
        self._stop = threading.Event()
        stop = self._stop

        def beat() -> None:
            while not stop.wait(interval):
                try:
                    os.utime(self.path)
                except OSError:
                    pass

        threading.Thread(target=beat, daemon=True, name=f"fcsweep-heartbeat-{self.path.parent.name}").start()

    def verify(self) -> None:
        """Raise :class:`LockLost` if the lock file no longer carries our token."""
        info = lock_info(self.path)
        if self.token is None or info is None or info.get("token") != self.token:
            who = f"pid {info.get('pid')} on {info.get('host')}" if info else "nobody"
            raise LockLost(f"{self.path} was taken over (now held by {who})")

    def release(self) -> None:
        """Stop the heartbeat and remove the lock if it is still ours."""
        if self._stop is not None:
            self._stop.set()
            self._stop = None
        if self.token is None:
            return
        info = lock_info(self.path)
        if info is not None and info.get("token") == self.token:
            try:
                self.path.unlink()
            except OSError:
                pass
        self.token = None

    def __enter__(self):
        if not self.acquire():
            raise LockHeld(self.path, self.held_by)
        return self

    def __exit__(self, *exc):
        self.release()
        return False
