"""Throughput of the step on this machine, and what it means for a sweep.

:func:`measure_throughput` times :meth:`fcsweep.simulation.Simulation.advance` after the
cells have left the lattice; :func:`bench_sweep` does so once per distinct cost setting of
a sweep (N, modes, K, quadrature, and the state parameters of the first run with them)
and turns the rates into the CPU time of the whole sweep.  Rates depend on the state
(contacts per cell), so a setting is timed at the parameters of its first run.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

#: Parameters that set the cost of one step (besides the state the dynamics reaches).
COST_KEYS = ("N", "modes", "contour_points", "quadrature")


def measure_throughput(params, *, steps, warm, threads=None, repeats=3) -> float:
    """Best-of-``repeats`` cell-steps per second of ``Simulation.advance`` (wall clock).

    Parameters
    ----------
    params : mapping
        Keyword arguments of :meth:`Simulation.from_lattice` (``N`` and ``seed`` included).
    steps : int
        Timed steps per repeat.
    warm : int
        Steps off the lattice before timing (the first call also compiles the kernels).
    threads : int, optional
        numba threads (default: leave numba's setting).
    """
    import numba

    from fcsweep.simulation import Simulation

    previous = numba.get_num_threads()
    if threads is not None:
        numba.set_num_threads(int(threads))
    try:
        sim = Simulation.from_lattice(**dict(params))
        sim.advance(int(warm))
        best = float("inf")
        for _ in range(repeats):
            t0 = time.perf_counter()
            sim.advance(int(steps))
            best = min(best, time.perf_counter() - t0)
    finally:
        numba.set_num_threads(previous)
    return sim.params.N * int(steps) / best


@dataclass(frozen=True)
class BenchRow:
    """One cost setting of a sweep: its measured rate and the work of its runs."""

    setting: dict
    runs: int
    cell_steps: float
    rate: float
    own: bool  # the sweep's own quadrature (not a --compare alternative)
    cell_steps_min: float | None = None  # with run.until: every run settled at its first check

    @property
    def cpu_seconds(self) -> float:
        """Serial time of all runs with this setting at the measured rate (at the cap)."""
        return self.cell_steps / self.rate

    @property
    def cpu_seconds_min(self) -> float:
        """With ``run.until``: the time if every run stops at its first possible check
        (``cpu_seconds`` without it); the ``until`` checks themselves are not counted."""
        return (self.cell_steps if self.cell_steps_min is None else self.cell_steps_min) / self.rate


def first_stop(run) -> int:
    """Fewest steps a run can do: the cap, or with ``run.until`` its first check step
    (the first multiple of ``check_every`` at or past ``min_steps``, at most the cap)."""
    if run.until is None:
        return run.steps
    u = run.until
    first = -(-max(u.min_steps, 1) // u.check_every) * u.check_every
    return min(run.steps, first)


def bench_sweep(cfg, *, steps=200, warm=2000, quadratures=None, threads=1, log=None) -> list[BenchRow]:
    """Measure every distinct cost setting of ``cfg`` (and, with ``quadratures``, the
    same settings with each of those rules instead) at ``threads`` numba threads.

    Returns one :class:`BenchRow` per (setting, quadrature), in order of first
    appearance; ``cell_steps`` is N x run.steps summed over the runs of the setting
    (the same runs for every quadrature compared), and with ``run.until``
    ``cell_steps_min`` is N x :func:`first_stop` summed likewise: the sweep costs
    between the two.
    """
    groups: dict[tuple, list] = {}
    for spec in cfg.runs():
        key = tuple(spec.params[k] for k in COST_KEYS)
        groups.setdefault(key, []).append(spec)
    rows = []
    for specs in groups.values():
        base = dict(specs[0].params)
        rules = [base["quadrature"]] if not quadratures or base["modes"] == 0 else list(quadratures)
        work = float(sum(s.params["N"] for s in specs)) * cfg.run.steps
        least = float(sum(s.params["N"] for s in specs)) * first_stop(cfg.run) if cfg.run.until else None
        for rule in rules:
            params = {**base, "quadrature": rule}
            per_block = max(int(steps * 1024 // params["N"]), 10)
            if log:
                log(f"timing N={params['N']} modes={params['modes']} K={params['contour_points']} {rule} ...")
            rate = measure_throughput(params, steps=per_block, warm=warm, threads=threads)
            rows.append(BenchRow({k: params[k] for k in COST_KEYS}, len(specs), work, rate,
                                 own=rule == base["quadrature"], cell_steps_min=least))
    return rows
