"""The cost of the step: CPU seconds per cell-step, measured once per machine and setting.

Every time estimate of fcsweep -- ``fcsweep bench``, ``fcsweep simulate --dry-run``, the
time left in ``fcsweep status`` and the cost lines in the comments of ``configs/*.yaml``
(``python benchmarks/readme_numbers.py --only configs``) -- multiplies cell-steps by :func:`cell_step_seconds`.

How a point (one run's parameters) is measured (:func:`measure_point`): the step is timed
on a **disordered start** of the run's cells (:meth:`~fcsweep.simulation.Simulation.from_disordered`
without its model relaxation: random centres pushed apart as soft discs, so every cell touches
its neighbours and neighbours in space are scattered in memory, as in a run that has flowed
for a while).  The cells first move for ``WARM_CELL_STEPS`` cell-steps (kernels are loaded),
then ``REPEATS`` blocks of ``BLOCK_CELL_STEPS`` cell-steps are timed at **one numba thread**
with the process CPU clock, and the median block gives the seconds per cell-step.  The
probe has at most :data:`PROBE_MAX_N` cells: the per-cell cost stops growing once a run's
arrays leave the caches (N = 99 856 and 10^6 ran at the same rate), and a start of 10^6
cells takes minutes.

Why the disordered start: the step costs what the contacts cost, and in a large run what
the scattering of neighbours in memory costs.  Just off the lattice (the "lattice probe"
column below), at area fraction 0.8, the cells do not yet touch and the step is cheaper
than in the run: the paper's Fig. 1c scene (N = 10^4) ran 1.9x longer than such a probe
said.  Measured in one process
(``benchmarks/cost_probe.py``, results in ``benchmarks/results/cost_probe.txt``; us per
cell-step, the runs after 50 time units from the lattice / from a disordered start):

==========================================  ======  =============  ==========
scene                                        probe  lattice probe  runs
==========================================  ======  =============  ==========
N = 1024, area fraction 0.8 (Fig. 1c)         0.82           0.60  0.90, 0.84
N = 10^4, area fraction 0.8 (Fig. 1c)         1.14           0.48  0.99, 1.20
N = 1024, 0.95, arc, fluid                    4.33           2.88  4.44, 4.04
N = 1024, 0.95, eta 0.1, v0 0.01 (solid)      1.05           0.80  0.78, 0.93
N = 10^4, 0.95, eta 0.1, v0 0.01 (solid)      1.41           0.92  0.90, 1.42
==========================================  ======  =============  ==========

So the estimate is the cost of a state that flows, or that started disordered; a solid
that never leaves its lattice runs up to 1.6x faster than estimated (the last rows),
where a lattice probe puts a flowing run up to 2.4x under.  Runs that start disordered
are timed on their own kind of start.

Both timing choices are what made the estimate stable on a loaded machine: the
former probe ran numba's default thread count, and on a 2-core machine shared with other
jobs a parallel step waits for whichever core is busy, so the same 1e5 cell-steps took
0.2 to 0.7 CPU s from one block to the next (the dry run of ``configs/phase.yaml`` said
83 h, then 4.6 h).  The CPU time of one thread counts none of the time the core spends
on other jobs; the median discards a block hit by a page fault or a migration.  Measured
at one thread, repeated probes of N = 1024 agree within 3 % on that machine.

A cost setting (:func:`setting_points`) is measured at its first and last run (the
corners of its grid: contacts, and so the cost of the arc rule, differ by up to 1.5x
between a jammed solid and a soft fluid) and the two are averaged.

Measurements are cached in ``<cache>/cost-<machine>.json`` (``<cache>``:
``$FCSWEEP_COST_CACHE``, else ``$XDG_CACHE_HOME/fcsweep`` or ``~/.cache/fcsweep``), keyed
by the run parameters without the seed, and valid for the same fcsweep version, kernel
sources, CPU model, core count and numba version, for ``MAX_AGE_DAYS`` days: a second
dry run, a bench and a status then quote the same number.  ``FCSWEEP_COST_CACHE=off``
measures every time.  ``fcsweep bench`` always measures and refreshes the cache.

Fallback (``measure=False`` and nothing cached, or a measurement that failed):
:data:`FALLBACK_US`, the one-thread CPU cost per cell-step at N = 1024 measured on the
2-core development machine (``benchmarks/results/throughput.txt``), times
:data:`CONTACT_INTEGRATOR_FACTOR` for the contact integrators.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import platform
import statistics
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Mapping, Sequence

from fcsweep.io.sweepdir import atomic_write

__all__ = ["CellStepCost", "cell_step_seconds", "measure_point", "setting_points", "fallback_seconds",
           "cache_file", "machine_fingerprint", "probe_params", "CACHE_ENV", "FALLBACK_US"]

#: Environment variable: directory of the cost cache, or ``off`` to measure every time.
CACHE_ENV = "FCSWEEP_COST_CACHE"
#: Cell-steps before timing, cell-steps per timed block, timed blocks.
WARM_CELL_STEPS, BLOCK_CELL_STEPS, REPEATS = 4e5, 1e5, 5
#: Most cells the step is timed at (362^2; a run with more is timed at this many).
PROBE_MAX_N = 362 * 362
#: The kind of probe, part of a cache entry's key (entries of the former lattice probe
#: are not read).
PROBE = "disordered"
#: Fewest steps in a warm-up or a timed block (small N).
MIN_STEPS = 10
#: Age after which a cached measurement is taken again.
MAX_AGE_DAYS = 30
#: One-thread CPU microseconds per cell-step at N = 1024, rho = 0.95, K = 40, M = 6 on
#: the 2-core development machine (benchmarks/results/throughput.txt); ``disc``: modes 0.
FALLBACK_US = {"binary": 0.887, "linear": 1.19, "arc": 2.45, "disc": 0.105}
#: The contact integrators' step costs about 1.5x Euler's (docs/speed_vs_error.md).
CONTACT_INTEGRATOR_FACTOR = 1.5
#: A step with adhesion on costs this many times one without (N = 1024, adhesion 0.1,
#: benchmarks/results/adhesion_ab.txt: 8.1x binary, 5.7x arc; other rules as binary).
ADHESION_FACTOR = {"arc": 5.7}
ADHESION_FACTOR_OTHER = 8.1
#: Parameters that never change the cost of a step.
_NOT_COST = ("seed",)


@dataclass(frozen=True)
class CellStepCost:
    """CPU seconds per cell-step of one cost setting.

    ``seconds``: mean over the setting's points; ``spread``: the largest relative spread
    (max - min over median) of the timed blocks of a point (0 if not measured);
    ``source``: ``"measured"`` (now), ``"cached"`` (an earlier measurement on this
    machine) or ``"fallback"`` (:data:`FALLBACK_US`).
    """

    seconds: float
    spread: float
    source: str

    @property
    def rate(self) -> float:
        """Cell-steps per CPU second."""
        return 1.0 / self.seconds

    def describe(self) -> str:
        """E.g. ``0.85 us per cell-step (cached measurement)``."""
        what = {"measured": "measured now", "cached": "measured earlier on this machine",
                "fallback": "no measurement: development-machine value"}.get(self.source, self.source)
        return f"{self.seconds * 1e6:.3g} us per cell-step ({what})"


def _point_key(params: Mapping, threads: int) -> str:
    p = {k: params[k] for k in sorted(params) if k not in _NOT_COST}
    return json.dumps({"params": p, "threads": int(threads), "probe": PROBE}, sort_keys=True, default=str)


def setting_points(specs) -> list[dict]:
    """Parameters at which a cost setting is measured: its first and last run (one if
    they coincide).  ``specs``: the :class:`~fcsweep.config.RunSpec` of the setting."""
    specs = list(specs)
    first, last = dict(specs[0].params), dict(specs[-1].params)
    drop = lambda p: {k: v for k, v in p.items() if k not in _NOT_COST}  # noqa: E731
    return [first] if drop(first) == drop(last) else [first, last]


def fallback_seconds(params: Mapping) -> float:
    """Documented CPU seconds per cell-step without a measurement (see the module doc)."""
    rule = "disc" if int(params.get("modes", 6)) == 0 else str(params.get("quadrature", "arc"))
    us = FALLBACK_US.get(rule, FALLBACK_US["arc"])
    if str(params.get("integrator", "euler")) != "euler":
        us *= CONTACT_INTEGRATOR_FACTOR
    if float(params.get("adhesion", 0.0)) > 0.0:
        us *= ADHESION_FACTOR.get(rule, ADHESION_FACTOR_OTHER)
    return us * 1e-6


def probe_params(params: Mapping) -> dict:
    """The parameters the step of a run is timed at: its own, started disordered, with at
    most :data:`PROBE_MAX_N` cells (``N`` = 362^2 above; a well of given radius then shrinks
    to keep the run's area fraction).

    Parameters
    ----------
    params : mapping
        Run parameters (keyword arguments of :meth:`fcsweep.simulation.Simulation.create`).

    Returns
    -------
    dict
        Keyword arguments of :meth:`fcsweep.simulation.Simulation.from_disordered`.
    """
    probe = {**dict(params), "initial": "disordered"}
    N = int(probe["N"])
    if N > PROBE_MAX_N:
        probe["N"] = PROBE_MAX_N
        if probe.get("boundary", "periodic") == "well" and float(probe.get("boundary_size", 0.0)) > 0:
            from fcsweep.model.confinement import confinement_of_params

            well = confinement_of_params(params)
            probe["boundary_size"] = 0.0
            probe["density"] = well.cell_area / (math.pi * well.size ** 2)
    return probe


def measure_point(params: Mapping, *, threads: int = 1, warm_cell_steps: float = WARM_CELL_STEPS,
                  block_cell_steps: float = BLOCK_CELL_STEPS, repeats: int = REPEATS) -> tuple[float, float]:
    """Time the step of a run at ``params`` on its :func:`probe_params` start (keyword
    arguments of :meth:`fcsweep.simulation.Simulation.create`).

    Returns
    -------
    seconds : float
        Median seconds per cell-step over ``repeats`` blocks: process CPU time at one
        thread; wall time with ``threads`` > 1 (the speed of one run given that many
        free cores; CPU time would add the threads' waiting).
    spread : float
        (max - min) / median of the blocks.
    """
    import numba

    from fcsweep.simulation import Simulation

    previous = numba.get_num_threads()
    numba.set_num_threads(max(1, min(int(threads), numba.config.NUMBA_NUM_THREADS)))
    try:
        probe = probe_params(params)
        sim = Simulation.from_disordered(relax_time=0.0, **probe)
        N = sim.params.N
        sim.advance(max(int(warm_cell_steps // N), MIN_STEPS))
        steps = max(int(block_cell_steps // N), MIN_STEPS)
        clock = time.process_time if int(threads) <= 1 else time.perf_counter
        blocks = []
        for _ in range(max(int(repeats), 1)):
            t0 = clock()
            sim.advance(steps)
            blocks.append(max(clock() - t0, 1e-9) / (N * steps))
    finally:
        numba.set_num_threads(previous)
    mid = statistics.median(blocks)
    return mid, (max(blocks) - min(blocks)) / mid


# ------------------------------------------------------------------ cache


def _cache_dir() -> Path | None:
    env = os.environ.get(CACHE_ENV)
    if env is not None and env.strip().lower() in ("off", "0", "no", "false", ""):
        return None
    if env:
        return Path(env)
    xdg = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(xdg) / "fcsweep"


def _cpu_model() -> str:
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.lower().startswith(("model name", "cpu model", "hardware")):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def machine_fingerprint() -> dict:
    """What a cached measurement is valid for: fcsweep version, kernel sources (the tag of
    the numba cache directory), CPU model, cores available, architecture, numba version."""
    import numba

    import fcsweep
    from fcsweep.io.machine import available_cores
    from fcsweep.kernels import cache_dir

    return {"fcsweep": fcsweep.__version__, "kernels": cache_dir().name, "cpu": _cpu_model(),
            "cores": available_cores(), "machine": platform.machine(), "numba": numba.__version__}


def cache_file() -> Path | None:
    """The cost cache of this machine, or None when caching is off (``FCSWEEP_COST_CACHE=off``)."""
    d = _cache_dir()
    if d is None:
        return None
    tag = hashlib.sha256(json.dumps(machine_fingerprint(), sort_keys=True).encode()).hexdigest()[:12]
    return d / f"cost-{tag}.json"


def _read(path: Path | None) -> dict:
    if path is None:
        return {}
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return {}
    return data.get("entries", {}) if isinstance(data, dict) else {}


def _write(path: Path | None, key: str, entry: dict) -> None:
    if path is None:
        return
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        entries = _read(path)  # another process may have added entries meanwhile
        entries[key] = entry
        text = json.dumps({"machine": machine_fingerprint(), "entries": entries}, indent=1, sort_keys=True)
        atomic_write(path, lambda tmp: tmp.write_text(text))
    except OSError:  # read-only home, full disk: estimates still work, they are just not kept
        pass


# ------------------------------------------------------------------ the model


def cell_step_seconds(points: Sequence[Mapping], *, threads: int = 1, cache: bool = True, measure: bool = True,
                      refresh: bool = False, log: Callable[[str], None] | None = None,
                      **measure_options) -> CellStepCost:
    """CPU seconds per cell-step of the step at ``points`` (mean over them).

    Parameters
    ----------
    points : sequence of mapping
        Run parameters of one cost setting (:func:`setting_points`).
    threads : int
        numba threads per run (1: CPU seconds; more: wall seconds with free cores).
    cache : bool
        Read and write the machine's cost cache (see the module docstring).
    measure : bool
        Time points that are not cached; if False they get :func:`fallback_seconds`.
    refresh : bool
        Measure even cached points and replace their entries (``fcsweep bench``).
    log : callable, optional
        Receives a line before each measurement.
    **measure_options
        ``warm_cell_steps``, ``block_cell_steps``, ``repeats`` of :func:`measure_point`;
        measurements made with other than the defaults are not cached.
    """
    path = cache_file() if cache else None
    entries = _read(path)
    now = time.time()
    seconds, spreads, sources = [], [], set()
    for params in points:
        key = _point_key(params, threads)
        hit = entries.get(key)
        if (hit and not refresh and not measure_options
                and now - float(hit.get("time", 0)) < MAX_AGE_DAYS * 86400 and float(hit.get("seconds", 0)) > 0):
            seconds.append(float(hit["seconds"]))
            spreads.append(float(hit.get("spread", 0.0)))
            sources.add("cached")
            continue
        if not measure:
            seconds.append(fallback_seconds(params))
            spreads.append(0.0)
            sources.add("fallback")
            continue
        if log:
            log(f"timing the step at N={params['N']} modes={params.get('modes')} K={params.get('contour_points')} "
                f"{params.get('quadrature')} {params.get('integrator', 'euler')} eta={params.get('eta')} "
                f"v0={params.get('v0')} ({threads} thread(s)) ...")
        try:
            s, spread = measure_point(params, threads=threads, **measure_options)
        except Exception as exc:  # noqa: BLE001 - an estimate must not stop the command
            if log:
                log(f"timing failed ({exc}); using the development machine's cost")
            seconds.append(fallback_seconds(params))
            spreads.append(0.0)
            sources.add("fallback")
            continue
        if not measure_options:
            _write(path, key, {"seconds": s, "spread": spread, "time": now,
                               "date": time.strftime("%Y-%m-%d %H:%M", time.localtime(now))})
        seconds.append(s)
        spreads.append(spread)
        sources.add("measured")
    source = next(s for s in ("fallback", "measured", "cached") if s in sources)
    return CellStepCost(sum(seconds) / len(seconds), max(spreads), source)
