"""Throughput of the step on this machine, and what it means for a sweep.

:func:`measure_throughput` times :meth:`fcsweep.simulation.Simulation.advance` after the
cells have left the lattice; :func:`bench_sweep` does so once per distinct cost setting of
a sweep (N, modes, K, quadrature, and the state parameters of the first run with them)
and turns the rates into the CPU time of the whole sweep.  Rates depend on the state
(contacts per cell), so a setting is timed at the parameters of its first run.

The cost model of a run (:func:`run_cpu_seconds`, :func:`run_seconds`), used by
``fcsweep bench`` and ``fcsweep simulate --dry-run``::

    cpu  = RUN_CPU_S + CHECKPOINT_CPU_S x checkpoints + N x steps / rate
    wall = cpu / share + RUN_IO_S + CHECKPOINT_IO_S x checkpoints

``rate`` is cell-steps per CPU second of the step, ``share`` the fraction of a core the
process gets on this machine now (CPU time / wall time while timing: on a machine
shared with other jobs it is well below 1, and it is why a rate timed as "best of 3" on
the wall clock underestimated runs by 2x); the constants are the CPU time a run spends
outside the step and per checkpoint, and the time it waits for the disk, measured on
the 2-core development machine with a local disk (``benchmarks/cost_model.py`` checks
the model against runs).  :func:`estimate_costs` calibrates ``rate x share`` per cost setting from the
sweep's own finished runs when there are any, else by timing the step now
(:func:`probe_cost`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

from fcsweep.io.status import read_status
from fcsweep.model.integrators import integrator_problem

#: CPU seconds a run spends outside the step (trajectory, lock and status files, final
#: rename) and per checkpoint (frames appended, checkpoint written), and the seconds
#: each waits for the disk (fsyncs): 2-core development machine, local disk.
RUN_CPU_S, RUN_IO_S = 0.05, 0.07
CHECKPOINT_CPU_S, CHECKPOINT_IO_S = 0.02, 0.03
#: CPU seconds of starting ``fcsweep simulate``: imports, loading the compiled kernels.
STARTUP_CPU_S = 2.0

#: Parameters that set the cost of one step (besides the state the dynamics reaches;
#: the contact integrators cost 1.5x Euler's step with the arc rule).
COST_KEYS = ("N", "modes", "contour_points", "quadrature", "integrator")


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
        # a quadrature the run's integrator cannot use (contact-jacobi needs arc) is not compared
        rules = [r for r in rules if r == base["quadrature"]
                 or integrator_problem(base["integrator"], r, base["modes"]) is None]
        work = float(sum(s.params["N"] for s in specs)) * cfg.run.steps
        least = float(sum(s.params["N"] for s in specs)) * first_stop(cfg.run) if cfg.run.until else None
        for rule in rules:
            params = {**base, "quadrature": rule}
            per_block = max(int(steps * 1024 // params["N"]), 10)
            if log:
                log(f"timing N={params['N']} modes={params['modes']} K={params['contour_points']} {rule} "
                    f"{params['integrator']} ...")
            rate = measure_throughput(params, steps=per_block, warm=warm, threads=threads)
            rows.append(BenchRow({k: params[k] for k in COST_KEYS}, len(specs), work, rate,
                                 own=rule == base["quadrature"], cell_steps_min=least))
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


def probe_cost(params_list, *, cell_steps: float = 1e5, blocks: int = 3, threads: int | None = None) -> StepCost:
    """Time the step from the lattice at each of ``params_list`` (the first and last
    run of a cost setting: the state changes the cost): one block of ``cell_steps``
    cell-steps to leave the lattice, then ``blocks`` timed blocks.  Returns the pooled
    rate (all timed cell-steps / their CPU time) and the CPU share of the process over
    them.  A few seconds per setting on this machine (after compilation)."""
    import numba

    from fcsweep.simulation import Simulation

    previous = numba.get_num_threads()
    if threads is not None:
        numba.set_num_threads(int(threads))
    work = cpu = wall = 0.0
    try:
        for params in params_list:
            N = int(params["N"])
            steps = max(int(cell_steps // N), 5)
            sim = Simulation.from_lattice(**dict(params))
            sim.advance(steps)
            threads_used = max(1, min(numba.get_num_threads(), N // 512))
            c0, w0 = time.process_time(), time.perf_counter()
            sim.advance(blocks * steps)
            cpu += (time.process_time() - c0) / threads_used
            wall += time.perf_counter() - w0
            work += N * blocks * steps
    finally:
        numba.set_num_threads(previous)
    share = min(cpu / max(wall, 1e-9), 1.0)
    rate = work / max(cpu, 1e-9)
    return StepCost(rate, share, f"step timed now: {rate:.3g} cell-steps per CPU s, {share:.0%} of a core free")


def cpu_share(seconds: float = 0.5) -> float:
    """Fraction of a core this process gets now (CPU / wall time of a busy loop)."""
    c0, w0 = time.process_time(), time.perf_counter()
    while time.perf_counter() - w0 < seconds:
        sum(range(10_000))
    return min((time.process_time() - c0) / max(time.perf_counter() - w0, 1e-9), 1.0)


def history_cost(cfg, specs) -> StepCost | None:
    """The step speed finished runs of ``specs`` reached: their wall time less the
    model's overheads, at the CPU share this process gets now (assuming the machine is
    as busy as when they ran); None if none is done."""
    done = []
    for spec in specs:
        st = read_status(cfg.run_dir(spec.run_id)) or {}
        if st.get("status") == "done" and st.get("wall_seconds") and st.get("steps_done"):
            done.append((int(spec.params["N"]), int(st["steps_done"]), float(st["wall_seconds"])))
    if not done:
        return None
    share = cpu_share()
    work = cpu = 0.0
    for N, steps, wall in done:
        k = -(-steps // cfg.run.checkpoint_every)
        step_cpu = (wall - RUN_IO_S - CHECKPOINT_IO_S * k) * share - RUN_CPU_S - CHECKPOINT_CPU_S * k
        if step_cpu > 0:
            work += N * steps
            cpu += step_cpu
    if not cpu:
        return None
    return StepCost(work / cpu, share, f"speed of {len(done)} finished run(s) of this sweep: "
                    f"{work / cpu * share:.3g} cell-steps per s, {share:.0%} of a core free now")


def estimate_costs(cfg, plans, *, log=None) -> tuple[list[tuple[float, float]], float, str]:
    """Estimated (CPU, wall) seconds of every planned run
    (:class:`fcsweep.sweep.plan.PlannedRun` with steps left), the CPU share of a core
    this process gets now, and a line saying how the estimate was calibrated.

    Per cost setting (:data:`COST_KEYS`): the speed of the sweep's finished runs with
    that setting if there are any, else :func:`probe_cost` at the first run's
    parameters (compiling the kernels first if needed).
    """
    groups: dict[tuple, list] = {}
    for spec in cfg.runs():
        groups.setdefault(tuple(spec.params[k] for k in COST_KEYS), []).append(spec)
    costs: dict[tuple, StepCost] = {}
    for p in plans:
        key = tuple(p.spec.params[k] for k in COST_KEYS)
        if key in costs:
            continue
        cost = history_cost(cfg, groups[key])
        if cost is None:
            from fcsweep.sweep.warmup import compile_kernels

            compile_kernels(log)
            if log:
                log("timing N={} modes={} K={} {} {} for the estimate ...".format(*key))
            members = groups[key]
            cost = probe_cost([members[0].params] + ([members[-1].params] if len(members) > 1 else []))
        costs[key] = cost
    out = []
    for p in plans:
        cost = costs[tuple(p.spec.params[k] for k in COST_KEYS)]
        every = cfg.run.checkpoint_every
        checkpoints = -(-(p.from_step + p.steps_left) // every) - p.from_step // every
        out.append((run_cpu_seconds(p.spec.params, p.steps_left, checkpoints, cost),
                    run_seconds(p.spec.params, p.steps_left, checkpoints, cost)))
    share = min((c.share for c in costs.values()), default=1.0)
    return out, share, "; ".join(sorted({c.source for c in costs.values()}))


def wall_time(seconds, processes: int) -> float:
    """Wall time of runs taking ``seconds`` each on ``processes`` processes that each take
    the next run when free (longest first; no run is split)."""
    free = [0.0] * max(int(processes), 1)
    for t in sorted(seconds, reverse=True):
        free[free.index(min(free))] += t
    return max(free)


def sweep_seconds(cfg, rows) -> list[tuple[float, float]]:
    """Estimated (CPU, wall) seconds of every run of ``cfg`` on a free core, from
    :func:`bench_sweep` rows of its own quadratures (rates timed on the wall clock)."""
    speed = {tuple(r.setting[k] for k in COST_KEYS): r.rate for r in rows}
    checkpoints = -(-cfg.run.steps // cfg.run.checkpoint_every)
    out = []
    for s in cfg.runs():
        cost = StepCost(speed[tuple(s.params[k] for k in COST_KEYS)], 1.0, "bench")
        out.append((run_cpu_seconds(s.params, cfg.run.steps, checkpoints, cost),
                    run_seconds(s.params, cfg.run.steps, checkpoints, cost)))
    return out
