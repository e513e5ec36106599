"""Throughput of the step on this machine, and what it means for a sweep.

Every estimate here rests on one number per cost setting, the CPU seconds per cell-step
of :func:`fcsweep.sweep.cost.cell_step_seconds` (timed at one thread with the process CPU
clock, median of repeats, cached per machine: see :mod:`fcsweep.sweep.cost`).
:func:`bench_sweep` measures it afresh for every distinct cost setting of a sweep (and
refreshes the cache); :func:`estimate_costs` (``fcsweep simulate --dry-run``) reads the
cache, measuring only settings not yet measured on this machine.  Both turn it into the
time of each run with the same model (:func:`run_cpu_seconds`, :func:`run_seconds`)::

    cpu  = RUN_CPU_S + CHECKPOINT_CPU_S x checkpoints + N x steps x seconds_per_cell_step
    wall = cpu / share + RUN_IO_S + CHECKPOINT_IO_S x checkpoints

with ``share`` = 1 (one free core per run): the load of other jobs changes from minute to
minute and is reported beside the estimate (:func:`cpu_share`), not folded into it, so
that two estimates of the same sweep agree.  The constants are the CPU time a run spends
outside the step and per checkpoint, and the time it waits for the disk, measured on the
2-core development machine with a local disk (``benchmarks/cost_model.py`` checks the
model against runs).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

from fcsweep.model.integrators import integrator_problem

#: CPU seconds a run spends outside the step (trajectory, lock and status files, final
#: rename) and per checkpoint (frames appended, checkpoint written), and the seconds
#: each waits for the disk (fsyncs): 2-core development machine, local disk.
RUN_CPU_S, RUN_IO_S = 0.05, 0.07
CHECKPOINT_CPU_S, CHECKPOINT_IO_S = 0.02, 0.03
#: CPU seconds of starting ``fcsweep simulate``: imports, loading the compiled kernels.
STARTUP_CPU_S = 2.0

#: Parameters that set the cost of one step (besides the state the dynamics reaches;
#: the contact integrators cost 1.5x Euler's step with the arc rule; adhesion 6-8x).
COST_KEYS = ("N", "modes", "contour_points", "quadrature", "integrator", "adhesion")


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
    spread: float = 0.0  # (max - min) / median of the timed blocks

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


def setting_groups(cfg, specs=None) -> dict[tuple, list]:
    """Runs of ``cfg`` (or ``specs``) grouped by cost setting (:data:`COST_KEYS`), in order
    of first appearance."""
    groups: dict[tuple, list] = {}
    for spec in (cfg.runs() if specs is None else specs):
        groups.setdefault(tuple(spec.params[k] for k in COST_KEYS), []).append(spec)
    return groups


def bench_sweep(cfg, *, steps=None, warm=None, quadratures=None, threads=1, log=None) -> list[BenchRow]:
    """Measure every distinct cost setting of ``cfg`` (and, with ``quadratures``, the
    same settings with each of those rules instead) at ``threads`` numba threads.

    Each setting is timed at its first and last run (:func:`fcsweep.sweep.cost.setting_points`)
    with :func:`fcsweep.sweep.cost.cell_step_seconds`, refreshing the machine's cost
    cache; ``steps`` (timed steps per block at N = 1024, scaled by 1024/N) and ``warm``
    (steps of the probe start before timing) replace its standard protocol, and such timings are not cached.

    Returns one :class:`BenchRow` per (setting, quadrature), in order of first
    appearance; ``cell_steps`` is N x run.steps summed over the runs of the setting
    (the same runs for every quadrature compared), and with ``run.until``
    ``cell_steps_min`` is N x :func:`first_stop` summed likewise: the sweep costs
    between the two.
    """
    from fcsweep.sweep.cost import PROBE_MAX_N, cell_step_seconds, setting_points

    rows = []
    for specs in setting_groups(cfg).values():
        base = dict(specs[0].params)
        rules = [base["quadrature"]] if not quadratures or base["modes"] == 0 else list(quadratures)
        # a quadrature the run's integrator cannot use (contact-jacobi needs arc) is not compared
        rules = [r for r in rules if r == base["quadrature"]
                 or integrator_problem(base["integrator"], r, base["modes"]) is None]
        work = float(sum(s.params["N"] for s in specs)) * cfg.run.steps
        least = float(sum(s.params["N"] for s in specs)) * first_stop(cfg.run) if cfg.run.until else None
        for rule in rules:
            points = [{**p, "quadrature": rule} for p in setting_points(specs)]
            options = {}
            if steps is not None:
                options["block_cell_steps"] = float(steps) * 1024
            if warm is not None:
                options["warm_cell_steps"] = float(warm) * min(int(base["N"]), PROBE_MAX_N)
            cost = cell_step_seconds(points, threads=threads, refresh=True, log=log, **options)
            rows.append(BenchRow({k: points[0][k] for k in COST_KEYS}, len(specs), work, cost.rate,
                                 own=rule == base["quadrature"], cell_steps_min=least, spread=cost.spread))
    return rows


# ------------------------------------------------------------------ cost model


@dataclass(frozen=True)
class StepCost:
    """Effective speed of the step for one cost setting.

    ``rate`` is cell-steps per CPU second, ``share`` the fraction of a core the process
    got (wall speed = rate x share); ``source`` says where the numbers come from.
    """

    rate: float
    share: float
    source: str

    @property
    def wall_rate(self) -> float:
        """Cell-steps per wall-clock second."""
        return self.rate * self.share


def run_cpu_seconds(params, steps: int, checkpoints: int, cost: StepCost) -> float:
    """Estimated CPU seconds of ``steps`` steps of one run with ``params``, writing
    ``checkpoints`` checkpoints (see the module docstring for the model)."""
    return RUN_CPU_S + CHECKPOINT_CPU_S * checkpoints + int(params["N"]) * int(steps) / cost.rate


def run_seconds(params, steps: int, checkpoints: int, cost: StepCost) -> float:
    """Estimated wall seconds of the same run: its CPU time at the CPU share of
    ``cost``, plus the time it waits for the disk."""
    return (run_cpu_seconds(params, steps, checkpoints, cost) / cost.share
            + RUN_IO_S + CHECKPOINT_IO_S * checkpoints)


def cpu_share(seconds: float = 0.5) -> float:
    """Fraction of a core this process gets now (CPU / wall time of a busy loop)."""
    c0, w0 = time.process_time(), time.perf_counter()
    while time.perf_counter() - w0 < seconds:
        sum(range(10_000))
    return min((time.process_time() - c0) / max(time.perf_counter() - w0, 1e-9), 1.0)


def estimate_costs(cfg, plans, *, log=None) -> tuple[list[tuple[float, float]], str]:
    """Estimated (CPU, wall) seconds of every planned run
    (:class:`fcsweep.sweep.plan.PlannedRun` with steps left), each on a free core, and a
    line saying where the cost per cell-step comes from.

    Per cost setting (:data:`COST_KEYS`): :func:`fcsweep.sweep.cost.cell_step_seconds`
    at the setting's first and last run -- the cached measurement of this machine, or a
    measurement now (compiling the kernels first if needed), which is then cached.
    """
    from fcsweep.sweep.cost import cell_step_seconds, setting_points

    groups = setting_groups(cfg)
    costs: dict[tuple, StepCost] = {}
    lines = []
    for p in plans:
        key = tuple(p.spec.params[k] for k in COST_KEYS)
        if key in costs:
            continue
        points = setting_points(groups[key])
        c = cell_step_seconds(points, measure=False)
        if c.source != "cached":
            from fcsweep.sweep.warmup import compile_kernels

            compile_kernels(log)
            c = cell_step_seconds(points, log=log)
        costs[key] = StepCost(c.rate, 1.0, c.source)
        lines.append(f"N={key[0]} {key[3]}: {c.describe()}")
    out = []
    for p in plans:
        cost = costs[tuple(p.spec.params[k] for k in COST_KEYS)]
        every = cfg.run.checkpoint_every
        checkpoints = -(-(p.from_step + p.steps_left) // every) - p.from_step // every
        out.append((run_cpu_seconds(p.spec.params, p.steps_left, checkpoints, cost),
                    run_seconds(p.spec.params, p.steps_left, checkpoints, cost)))
    return out, "; ".join(lines)


def wall_time(seconds, processes: int) -> float:
    """Wall time of runs taking ``seconds`` each on ``processes`` processes that each take
    the next run when free (longest first; no run is split)."""
    free = [0.0] * max(int(processes), 1)
    for t in sorted(seconds, reverse=True):
        free[free.index(min(free))] += t
    return max(free)


def sweep_seconds(cfg, rows) -> list[tuple[float, float]]:
    """Estimated (CPU, wall) seconds of every run of ``cfg`` on a free core, from
    :func:`bench_sweep` rows of its own quadratures (the model of :func:`estimate_costs`)."""
    speed = {tuple(r.setting[k] for k in COST_KEYS): r.rate for r in rows}
    checkpoints = -(-cfg.run.steps // cfg.run.checkpoint_every)
    out = []
    for s in cfg.runs():
        cost = StepCost(speed[tuple(s.params[k] for k in COST_KEYS)], 1.0, "bench")
        out.append((run_cpu_seconds(s.params, cfg.run.steps, checkpoints, cost),
                    run_seconds(s.params, cfg.run.steps, checkpoints, cost)))
    return out


def bench_report(cfg, rows, *, threads: int, workers: int) -> dict:
    """What ``fcsweep bench`` reports of ``rows`` (:func:`bench_sweep`), as its ``--json``
    prints it: every row, the sweep's CPU seconds at the cap (and, with ``run.until``,
    if every run settles at its first check), the wall seconds on ``workers`` processes
    (capped at the cores), and this process's share of a core now."""
    from fcsweep.io.machine import worker_layout

    per_run = sweep_seconds(cfg, [r for r in rows if r.own])  # its own rules, not the --compare ones
    processes, _ = worker_layout(workers)
    return {"rows": [{**r.setting, "runs": r.runs, "cell_steps": r.cell_steps, "cell_steps_min": r.cell_steps_min,
                      "cell_steps_per_s": r.rate, "cpu_seconds": r.cpu_seconds,
                      "cpu_seconds_min": r.cpu_seconds_min, "spread": r.spread}
                     for r in rows],
            "sweep_cpu_seconds": sum(c for c, _ in per_run),
            "sweep_cpu_seconds_min": sum(r.cpu_seconds_min for r in rows if r.own),
            "processes": processes, "sweep_wall_seconds": wall_time([w for _, w in per_run], processes),
            "threads": threads, "cpu_share_now": cpu_share()}


def format_bench(cfg, rows, report: dict) -> list[str]:
    """The table and summary lines of ``fcsweep bench`` (``report``: :func:`bench_report`)."""
    from fcsweep.sweep.progress import format_duration

    cpu, wall, share = report["sweep_cpu_seconds"], report["sweep_wall_seconds"], report["cpu_share_now"]
    lines = [f"{'N':>6} {'modes':>5} {'K':>4} {'quadrature':>10} {'integrator':>16} {'runs':>5} "
             f"{'cell-steps/s':>13} {'us/cell-step':>12} {'spread':>6} {'CPU time of these runs':>23}"]
    for r in rows:
        st = r.setting
        lines.append(f"{st['N']:>6} {st['modes']:>5} {st['contour_points']:>4} {st['quadrature']:>10} "
                     f"{st['integrator']:>16} {r.runs:>5} {r.rate:>13.3e} {1e6 / r.rate:>12.3f} {r.spread:>6.0%} "
                     f"{format_duration(r.cpu_seconds):>23}")
    lines.append(f"sweep ({len(cfg.runs())} runs, {cfg.run.steps} steps each, its own quadratures): "
                 f"{format_duration(cpu)} of CPU at {report['threads']} thread(s) per run, writing included; "
                 f"about {format_duration(wall)} wall on {report['processes']} process(es)")
    if share < 0.9:
        lines.append(f"note: other jobs share this machine (this process gets {share:.0%} of a core now); the CPU "
                     f"times hold, the wall time assumes free cores (at this load: about "
                     f"{format_duration(wall / share)})")
    if cfg.run.until:
        lines.append(f"with run.until: between {format_duration(report['sweep_cpu_seconds_min'])} (every run "
                     f"settled at its first check, {first_stop(cfg.run)} steps) and {format_duration(cpu)} of CPU "
                     f"(every run to the cap, {cfg.run.steps} steps), plus the checks")
    return lines
