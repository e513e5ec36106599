"""Graceful stop on SIGTERM / SIGINT / SIGUSR1: a flag, never an exception.

The handler only records the signal.  The run loop (:mod:`fcsweep.sweep.runner`) checks
the flag between pieces of integration of at most about half a second, writes a checkpoint
at the current step, marks the run ``interrupted`` and returns; the executors stop handing
out runs.  Raising from a signal handler instead can land inside a
weakref callback or a ``finally`` block, where Python prints "Exception ignored" and the
run simply goes on.

A second signal while the first is being handled restores the default action and
re-sends the signal, so an impatient operator can still kill the process at once (the run
then resumes from its previous checkpoint, as after SIGKILL).

Exit codes follow the shell convention ``128 + signal number``: SIGINT 130, SIGTERM 143,
SIGUSR1 138.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
from contextlib import contextmanager
from typing import Iterator

__all__ = ["SIGNALS", "install", "requested", "reason", "request", "clear", "exit_code", "handling",
           "NOT_STARTED", "interrupted_counts", "interrupted_phrase"]

#: Message of an ``interrupted`` outcome for a run that never began (the stop came first).
NOT_STARTED = "not started"

#: Signals that stop a sweep gracefully (batch time limits and scancel send SIGTERM;
#: ``sbatch --signal=B:USR1@60`` can ask for SIGUSR1 ahead of the limit).
SIGNALS = (signal.SIGTERM, signal.SIGINT, signal.SIGUSR1)

_received: list[int] = []
_lock = threading.Lock()


def _handler(signum, frame) -> None:
    if _received:  # second signal: the operator insists
        signal.signal(signum, signal.SIG_DFL)
        os.kill(os.getpid(), signum)
        return
    _received.append(signum)
    try:
        os.write(sys.stderr.fileno(), f"fcsweep: {signal.Signals(signum).name} received; checkpointing at the "
                                      f"current step (send it again to stop at once)\n".encode())
    except (OSError, ValueError, AttributeError):
        pass


def install() -> dict[int, object]:
    """Install the flag-setting handler for :data:`SIGNALS`; returns the previous handlers.

    Only possible in the main thread; elsewhere nothing is installed (``{}``).
    """
    previous: dict[int, object] = {}
    if threading.current_thread() is not threading.main_thread():
        return previous
    for sig in SIGNALS:
        try:
            previous[sig] = signal.signal(sig, _handler)
        except (ValueError, OSError):  # pragma: no cover - unsupported signal
            pass
    return previous


def restore(previous: dict[int, object]) -> None:
    """Put back the handlers returned by :func:`install`."""
    for sig, old in previous.items():
        try:
            signal.signal(sig, old)
        except (ValueError, OSError, TypeError):  # pragma: no cover
            pass


@contextmanager
def handling() -> Iterator[None]:
    """``with handling(): ...`` -- the handler is installed inside the block only."""
    previous = install()
    try:
        yield
    finally:
        restore(previous)


def requested() -> int | None:
    """The signal number received, or ``None``."""
    return _received[0] if _received else None


def reason() -> str | None:
    """E.g. ``"SIGTERM"`` if a stop was requested, else ``None``."""
    sig = requested()
    return None if sig is None else signal.Signals(sig).name


def request(signum: int = signal.SIGTERM) -> None:
    """Request a stop as if ``signum`` had been received (other threads, tests)."""
    with _lock:
        if not _received:
            _received.append(int(signum))


def clear() -> None:
    """Forget a received signal (tests; a new sweep in the same process)."""
    with _lock:
        _received.clear()


def exit_code(signum: int) -> int:
    """Shell convention: ``128 + signum`` (SIGINT 130, SIGTERM 143)."""
    return 128 + int(signum)


def interrupted_counts(outcomes) -> tuple[int, int]:
    """(stopped, not_started) among the ``interrupted`` outcomes of a sweep: runs stopped
    while computing (each wrote a checkpoint at its current step) and runs never begun
    because the stop came first (nothing to checkpoint; the next ``simulate`` starts them)."""
    hit = [o for o in outcomes if o.outcome == "interrupted"]
    not_started = sum(o.message == NOT_STARTED for o in hit)
    return len(hit) - not_started, not_started


def interrupted_phrase(outcomes) -> str:
    """E.g. ``1 stopped and checkpointed, 1 not started`` (empty without interrupted
    runs): one wording for the summary line and the stop line, so their counts agree."""
    stopped, not_started = interrupted_counts(outcomes)
    parts = ([f"{stopped} stopped and checkpointed"] if stopped else []) + \
        ([f"{not_started} not started"] if not_started else [])
    return ", ".join(parts)
