"""Compile (or load) the numba kernels before any run starts, with progress and an estimate.

The first use of the kernels compiles them (minutes on a busy 2-core machine), later
uses load them from the on-disk cache (:func:`fcsweep.kernels.cache_dir`, keyed by a
hash of the kernel sources) in about a second.  :func:`compile_kernels` does this once,
before the runs of a sweep start, so the compile time is neither silent nor charged to
the first run's wall time.  Every quadrature rule, integrator and boundary is a run-time
branch of the same compiled step, so the demo's step (binary rule, Euler, periodic box)
is the one signature every config needs: one compilation serves all of them.

The step is one entry point (:func:`fcsweep.kernels.step.run_chunk`) over separately
cached kernels.  With ``parallel=True`` the kernels it calls are compiled in
:data:`STAGES`: the rate kernel (:func:`fcsweep.kernels.rates.all_rates`, about two
thirds of the time) in one process, the other kernels in another, both into the shared
cache (numba writes every cache file under a unique temporary name and renames it, and
the two processes compile disjoint functions, so neither overwrites the other's index),
then the step itself in the calling process, which loads the kernels from the cache.
The rate kernel is the floor: a cold compile takes about as long as it alone.

Progress: a bar with the elapsed time and an estimate on a terminal (tqdm), else one
line per stage (logs stay short).  The estimate scales :data:`STAGES`' reference
seconds by how fast the finished stages went on this machine.
"""

from __future__ import annotations

import multiprocessing
import sys
import threading
import time
from pathlib import Path
from typing import Callable

__all__ = ["STAGES", "cache_dir", "kernels_cached", "compile_kernels", "leaf_jobs"]

#: Cached entry points: their index files tell whether the cache holds compiled code.
_ENTRY_POINTS = ("step.run_chunk",)

#: The stages of a cold compile: (name, what, kernels, reference seconds).  The
#: reference seconds were measured on the 2-core development machine (loaded: another
#: compile ran beside it) and only set the first estimate and the stages' shares.
STAGES = (
    ("rates", "rate kernel", ("rates.all_rates",), 320.0),
    ("others", "geometry, neighbour lists, adhesion, walls, contacts, update",
     ("geometry.geometry", "celllist.grid_shape", "verlet.needs_rebuild", "celllist.build_cell_list",
      "verlet.build_verlet", "verlet.build_back", "adhesion.adhesion_rates", "walls.wall_rates",
      "rates.contact_sweeps", "step.euler_update"), 56.0),
    ("step", "step", ("step.compute_rates", "step.run_chunk"), 19.0),
)


def cache_dir() -> Path:
    """The directory numba caches the compiled kernels in (for this kernel source)."""
    from fcsweep.kernels import cache_dir as kernels_cache_dir

    return kernels_cache_dir()


def _source_cache_dir() -> Path:
    """Numba's subdirectory of :func:`cache_dir` for the kernels of this installation
    (``kernels_<sha1 of the source directory>``, as numba's cache locator names it)."""
    import hashlib
    import os

    import fcsweep.kernels

    src = os.path.dirname(os.path.abspath(fcsweep.kernels.__file__))
    return cache_dir() / f"kernels_{hashlib.sha1(src.encode()).hexdigest()}"


def kernels_cached() -> bool:
    """True when the cache holds compiled code of every entry point (index files
    ``<module>.<function>-<line>.py<ver>.nbi`` that numba writes next to the code)."""
    d = _source_cache_dir()
    return d.is_dir() and all(any(d.glob(f"{name}-*.nbi")) for name in _ENTRY_POINTS)


def _demo_simulation():
    """A 16-cell system of the demo's kinds (binary rule, Euler, periodic box): the
    argument types of every kernel the demo calls (sizes do not enter the types)."""
    from fcsweep.simulation import Simulation

    return Simulation.from_lattice(16, eta=0.1, v0=0.01, seed=0, modes=2, contour_points=8, quadrature="binary")


def leaf_jobs(stage: str):
    """(dispatcher, argument types) of the kernels :func:`fcsweep.kernels.step.compute_rates`
    and :func:`fcsweep.kernels.step.run_chunk` call, for one stage of :data:`STAGES`
    (``rates`` or ``others``), with the types those calls have in the demo's step."""
    import numba
    import numpy as np

    from fcsweep.kernels import adhesion, celllist, geometry, rates, step, verlet, walls
    from fcsweep.kernels.api import param_vector
    from fcsweep.kernels.pairs import QUAD_ARC
    from fcsweep.kernels.records import P_LX, P_LY, P_R0, P_SKIN
    from fcsweep.kernels.workspace import quadrature_code, workspace_for

    N, K, M1 = 16, 8, 1
    rng = np.random.default_rng(0)
    pos, image = rng.uniform(0.0, 8.0, (N, 2)), np.zeros((N, 2), np.int64)
    theta, a, b = rng.uniform(0.0, 6.0, N), np.zeros((N, M1)), np.zeros((N, M1))
    box = (8.0, 8.0)
    ws = workspace_for(N, K, M1, box, 1.0, "binary")
    prm = param_vector(box=box, R0=1.0, eta=0.1, v0=0.01, mu_theta=1.0, mu_shape=1.0, dt=0.001)
    quad, periodic, use_list = quadrature_code("binary"), True, True
    tables, scratch, cl, nl, out = ws.tables, ws.scratch, ws.cl, ws.nl, ws.out
    geo = scratch.geo
    Lx, Ly, skin = prm[P_LX], prm[P_LY], prm[P_SKIN]
    noise = np.zeros((2, N))
    if stage == "rates":
        calls = [(rates.all_rates, (pos, a, b, prm, periodic, quad, tables, scratch, nl, out, use_list, False))]
    elif stage == "others":
        calls = [
            (geometry.geometry, (theta, a, b, prm[P_R0], tables, scratch, quad == QUAD_ARC)),
            (celllist.grid_shape, (Lx, Ly, 2.0 * Lx, pos.shape[0])),
            (verlet.needs_rebuild, (pos, geo, nl.ref_pos, nl.ref_rb, Lx, Ly, skin)),
            (celllist.build_cell_list, (pos, Lx, Ly, 3, 3, *cl)),
            (verlet.build_verlet, (pos, geo, Lx, Ly, skin, 3, 3, *cl, nl.nbr, nl.count, nl.ref_pos, nl.ref_rb)),
            (verlet.build_back, (nl.nbr, nl.count, nl.back)),
            (adhesion.adhesion_rates, (pos, a, b, prm, periodic, tables, scratch, nl, out, use_list)),
            (walls.wall_rates, (pos, a, b, prm, quad, tables, scratch, out)),
            (rates.contact_sweeps, (a, b, prm, scratch, nl, out, np.int64(1))),
            (step.euler_update, (pos, image, theta, a, b, out, noise[0], prm, periodic, ws.flags)),
        ]
    else:
        raise ValueError(f"stage must be 'rates' or 'others'; got {stage!r}")
    return [(disp, tuple(numba.typeof(v) for v in args)) for disp, args in calls]


def _compile_stage(stage: str) -> None:
    """Compile one stage's kernels into the cache (the body of a stage's process)."""
    for disp, sig in leaf_jobs(stage):
        disp.compile(sig)


def _step_stage() -> None:
    """Compile (or load) the step in this process by stepping a 16-cell system once."""
    _demo_simulation().advance(1)


class _Estimate:
    """The expected seconds of a cold compile: the reference seconds of the critical
    path, scaled by how much slower or faster the finished stages were."""

    def __init__(self, parallel: bool):
        ref = {name: sec for name, _, _, sec in STAGES}
        self.ref = ref
        self.path = (max(ref["rates"], ref["others"]) if parallel else ref["rates"] + ref["others"]) + ref["step"]
        self.scale = 1.0

    def finished(self, name: str, seconds: float, parallel: bool) -> None:
        # the stages of a parallel compile share the cores: the slower one sets the scale
        if not parallel or name != "others":
            self.scale = max(seconds, 1.0) / self.ref[name]

    def total(self) -> float:
        return self.path * self.scale


def _run_parallel(done: Callable[[str, float], None]) -> None:
    """The ``rates`` and ``others`` stages in two processes (spawned: no inherited numba
    state), then the step here; ``done(stage, seconds)`` after each.  A stage whose
    process fails is compiled here instead."""
    ctx = multiprocessing.get_context("spawn")
    t0 = time.perf_counter()
    procs = {name: ctx.Process(target=_compile_stage, args=(name,), name=f"fcsweep-compile-{name}", daemon=True)
             for name in ("rates", "others")}  # daemons: an interrupted compile does not wait for them
    for p in procs.values():
        p.start()
    left = dict(procs)
    try:
        while left:
            for name, p in list(left.items()):
                p.join(timeout=0.2)
                if p.exitcode is not None:
                    del left[name]
                    if p.exitcode != 0:
                        _compile_stage(name)
                    done(name, time.perf_counter() - t0)
    finally:
        for p in left.values():  # interrupted: stop the other stage too
            p.terminate()
    t1 = time.perf_counter()
    _step_stage()
    done("step", time.perf_counter() - t1)


def _run_serial(done: Callable[[str, float], None]) -> None:
    """The stages one after the other in this process."""
    for name in ("rates", "others"):
        t = time.perf_counter()
        _compile_stage(name)
        done(name, time.perf_counter() - t)
    t = time.perf_counter()
    _step_stage()
    done("step", time.perf_counter() - t)


def compile_kernels(log: Callable[[str], None] | None = None, *, tick: float | None = None, parallel: bool = False,
                    progress: bool | None = None) -> float:
    """Compile or load the kernels the demo's step needs (every config uses the same).

    Parameters
    ----------
    log : callable, optional
        Receives a line when compilation starts (only when the cache is cold), a line per
        finished stage (or, on a terminal with ``progress``, a bar instead), and one
        when it is over.
    tick : float, optional
        Seconds between elapsed-time lines while a stage runs (without a bar; default
        none: a log gets a line per stage and no more).
    parallel : bool
        Compile the stages in two processes (where the caller may start processes; a
        daemonic process, such as a pool worker, compiles in itself).
    progress : bool, optional
        Draw a progress bar with an estimate on stderr (default: when stderr is a
        terminal and ``log`` is given).

    Returns
    -------
    float
        Seconds it took (about 1 s when the cache was warm).
    """
    cold = not kernels_cached()
    t0 = time.perf_counter()
    if not cold:
        _step_stage()
        return time.perf_counter() - t0
    parallel = parallel and not multiprocessing.current_process().daemon
    if progress is None:
        progress = log is not None and sys.stderr.isatty()
    est = _Estimate(parallel)
    if log:
        log(f"compiling kernels (first use, cached in {cache_dir()}); about {est.total() / 60:.0f} min "
            f"({'two processes' if parallel else 'one process'}), once per fcsweep version")
    what = {name: text for name, text, _, _ in STAGES}
    finished: list[str] = []
    stop = threading.Event()
    bar = None
    if progress and log:
        from tqdm.auto import tqdm

        bar = tqdm(total=round(est.total()), desc="compiling kernels", unit="s", file=sys.stderr,
                   bar_format="{desc}: {percentage:3.0f}%|{bar}| {n:.0f}/{total:.0f} s{postfix}")

    def done(name: str, seconds: float) -> None:
        finished.append(name)
        est.finished(name, seconds, parallel)
        if bar is not None:
            bar.total = max(round(est.total()), round(time.perf_counter() - t0) + 1)
            bar.set_postfix_str(f"{what[name]} done")
        elif log:
            left = max(est.total() - (time.perf_counter() - t0), 0.0)
            log(f"compiled the {what[name]} ({len(finished)}/{len(STAGES)}) at "
                f"{time.perf_counter() - t0:.0f} s" + (f"; about {left:.0f} s left" if name != "step" else ""))

    def ticker():
        while not stop.wait(0.5 if bar is not None else tick):
            now = time.perf_counter()
            if bar is not None:
                bar.n = min(now - t0, bar.total - 1)
                bar.refresh()
            else:
                log(f"compiling kernels ... {now - t0:.0f} s")

    th = threading.Thread(target=ticker, daemon=True) if log and (bar is not None or tick) else None
    if th:
        th.start()
    try:
        (_run_parallel if parallel else _run_serial)(done)
    finally:
        stop.set()
        if th:
            th.join()
        if bar is not None:
            bar.n = bar.total = round(time.perf_counter() - t0)
            bar.refresh()
            bar.close()
    seconds = time.perf_counter() - t0
    if log:
        log(f"kernels compiled in {seconds:.0f} s")
    return seconds
