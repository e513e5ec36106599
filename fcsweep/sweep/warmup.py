"""Compile (or load) the numba kernels before any run starts, saying so.

The first use of the kernels compiles them (minutes on a busy 2-core machine; numba
reports no progress), later uses load them from the on-disk cache
(:data:`fcsweep.kernels.CACHE_DIR`, keyed by a hash of the kernel sources) in about a
second.  :func:`compile_kernels` does this once, in the calling process, before the runs
of a sweep start, so the compile time is neither silent nor charged to the first run's
wall time.  Every quadrature rule is a run-time branch of the same compiled step, so
one compilation serves all configs.
"""

from __future__ import annotations

import hashlib
import os
import threading
import time
from pathlib import Path
from typing import Callable

__all__ = ["cache_dir", "kernels_cached", "compile_kernels"]

#: Cached entry points: their index files tell whether the cache holds compiled code.
_ENTRY_POINTS = ("step.run_chunk",)


def cache_dir() -> Path:
    """The directory numba caches the compiled kernels in (for this kernel source)."""
    from fcsweep.kernels import CACHE_DIR

    return Path(CACHE_DIR)


def _source_cache_dir() -> Path:
    """Numba's subdirectory of :func:`cache_dir` for the kernels of this installation
    (``kernels_<sha1 of the source directory>``, as numba's cache locator names it)."""
    import fcsweep.kernels

    src = os.path.dirname(os.path.abspath(fcsweep.kernels.__file__))
    return cache_dir() / f"kernels_{hashlib.sha1(src.encode()).hexdigest()}"


def kernels_cached() -> bool:
    """True when the cache holds compiled code of every entry point (index files
    ``<module>.<function>-<line>.py<ver>.nbi`` that numba writes next to the code)."""
    d = _source_cache_dir()
    return d.is_dir() and all(any(d.glob(f"{name}-*.nbi")) for name in _ENTRY_POINTS)


def compile_kernels(log: Callable[[str], None] | None = None, *, tick: float = 15.0) -> float:
    """Compile or load the kernels in this process by stepping a 16-cell system once.

    Parameters
    ----------
    log : callable, optional
        Receives a line when compilation starts (only when the cache is cold), an
        elapsed-time line every ``tick`` seconds meanwhile, and one when it is over.
    tick : float
        Seconds between elapsed-time lines (numba gives no finer progress).

    Returns
    -------
    float
        Seconds it took (about 1 s when the cache was warm).
    """
    from fcsweep.simulation import Simulation

    cold = not kernels_cached()
    if cold and log:
        log(f"compiling kernels (first use, cached in {cache_dir()}); this takes 1-10 min "
            f"on a busy 2-core machine and happens once per fcsweep version")
    stop = threading.Event()
    t0 = time.perf_counter()

    def ticker():
        while not stop.wait(tick):
            log(f"compiling kernels ... {time.perf_counter() - t0:.0f} s")

    th = threading.Thread(target=ticker, daemon=True) if (cold and log) else None
    if th:
        th.start()
    try:
        sim = Simulation.from_lattice(16, eta=0.1, v0=0.01, seed=0, modes=2, contour_points=8,
                                      quadrature="binary")
        sim.advance(1)
    finally:
        stop.set()
        if th:
            th.join()
    seconds = time.perf_counter() - t0
    if cold and log:
        log(f"kernels compiled in {seconds:.0f} s")
    return seconds
