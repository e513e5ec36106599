"""Faults made on purpose, for the tests of kills, failed writes and failed runs: one module,
one grammar, read from environment variables (inherited by ``-j`` worker processes).

``FCSWEEP_TEST_KILL_AT=[<file>:]<point>[:K]``
    SIGKILL the process the K-th time (default the 1st) it reaches ``point``.  The points of
    an atomic write (:mod:`fcsweep.io.atomic`) need ``<file>``, a glob matched against the
    name of the file written: ``written`` (temporary file complete, not yet fsynced),
    ``before-rename``, ``after-rename`` (before the directory fsync).  The points of a
    computing run (:mod:`fcsweep.sweep.runner`, :mod:`fcsweep.sweep.writer`) take no file:
    ``frame`` (a frame was sampled), ``h5-append`` (datasets grown, data not yet written),
    ``checkpoint-write`` (temporary checkpoint written, not yet renamed), ``checkpoint``
    (checkpoint in place), ``finalize`` (trajectory renamed, status not yet written).
``FCSWEEP_TEST_WRITE_ERROR=<file>:<ERRNO>``
    The atomic write of a file named ``<file>`` (a glob) fails with ``ERRNO`` (``ENOSPC``,
    ``EDQUOT``, ``EROFS``, ``EACCES``) after its temporary file was created.
``FCSWEEP_TEST_SLOW=<seconds>``
    A computing run sleeps this long after each frame, so that a test can signal it mid-way.
``FCSWEEP_FAIL_RUN_IDS=<id>[,<id>...]``
    These runs raise an injected ``RuntimeError`` after their first frame.

:func:`faults` parses the variables (once for each set of values) into a :class:`Faults`;
its ``active`` is False when none is set, so that the loops of a run ask once
(``if faults.active``) and production runs do no more than that.
"""

from __future__ import annotations

import errno as _errno
import fnmatch
import os
import signal
import time
from collections import Counter
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

__all__ = ["Faults", "faults", "KILL_AT", "WRITE_ERROR", "SLOW", "FAIL_RUN_IDS", "WRITE_POINTS", "RUN_POINTS"]

KILL_AT, WRITE_ERROR, SLOW, FAIL_RUN_IDS = ("FCSWEEP_TEST_KILL_AT", "FCSWEEP_TEST_WRITE_ERROR", "FCSWEEP_TEST_SLOW",
                                            "FCSWEEP_FAIL_RUN_IDS")
#: Points of an atomic write (they need a file pattern).
WRITE_POINTS = ("written", "before-rename", "after-rename")
#: Points of a computing run (no file pattern).
RUN_POINTS = ("frame", "h5-append", "checkpoint-write", "checkpoint", "finalize")

#: How many times this process reached each (pattern, point) of the kill spec.
_reached: Counter = Counter()


@dataclass(frozen=True)
class Faults:
    """The faults asked for (module docstring); an instance with nothing set does nothing."""

    kill_pattern: str | None = None
    kill_point: str | None = None
    kill_count: int = 1
    error_pattern: str | None = None
    error_code: int | None = None
    slow_seconds: float = 0.0
    fail_run_ids: frozenset = frozenset()

    @property
    def active(self) -> bool:
        return bool(self.kill_point or self.error_code or self.slow_seconds or self.fail_run_ids)

    def kill(self, point: str, path=None) -> None:
        """SIGKILL this process if this is the K-th time it reaches ``point`` (of the write of
        ``path``, for the points of an atomic write)."""
        if point != self.kill_point:
            return
        if self.kill_pattern is not None and (path is None or not fnmatch.fnmatch(Path(path).name,
                                                                                    self.kill_pattern)):
            return
        _reached[(self.kill_pattern, point)] += 1
        if _reached[(self.kill_pattern, point)] == self.kill_count:
            os.kill(os.getpid(), signal.SIGKILL)

    def write_error(self, path) -> None:
        """Raise the ``OSError`` asked for at the write of ``path``."""
        if self.error_code is not None and fnmatch.fnmatch(Path(path).name, self.error_pattern):
            raise OSError(self.error_code, os.strerror(self.error_code), str(path))

    def fail_run(self, run_id: str) -> None:
        """Raise the injected failure of ``run_id`` (asked once, before its first frame is kept)."""
        if run_id in self.fail_run_ids:
            raise RuntimeError(f"injected failure for run {run_id} ({FAIL_RUN_IDS})")

    def after_frame(self) -> None:
        """The faults of a computing run after a frame was sampled: the kill at ``frame``,
        then the sleep."""
        self.kill("frame")
        if self.slow_seconds:
            time.sleep(self.slow_seconds)


@lru_cache(maxsize=8)
def _parse(kill: str, error: str, slow: str, fail: str) -> Faults:
    out = {}
    parts = kill.split(":") if kill else []
    if parts:
        k = int(parts.pop()) if len(parts) > 1 and parts[-1].isdigit() else 1
        point = parts.pop() if parts else ""
        pattern = ":".join(parts) or None
        if point in WRITE_POINTS + RUN_POINTS and (pattern is None) == (point in RUN_POINTS):
            out.update(kill_pattern=pattern, kill_point=point, kill_count=k)
    pattern, _, name = error.rpartition(":")
    if pattern and hasattr(_errno, name):
        out.update(error_pattern=pattern, error_code=getattr(_errno, name))
    if slow:
        out["slow_seconds"] = float(slow)
    out["fail_run_ids"] = frozenset(s.strip() for s in fail.split(",") if s.strip())
    return Faults(**out)


def faults() -> Faults:
    """The :class:`Faults` the environment asks for now."""
    env = os.environ
    return _parse(env.get(KILL_AT, ""), env.get(WRITE_ERROR, ""), env.get(SLOW, ""), env.get(FAIL_RUN_IDS, ""))
