"""Resource bounds and physical limits of a sweep: what keeps every command fast and
bounded in memory whatever a file says (runs are counted before any grid is expanded),
and what keeps the integration faithful.  configs/README.md ("Allowed ranges")
documents each of them."""

from __future__ import annotations

import itertools
import math
import os
from pathlib import Path
from typing import TYPE_CHECKING, Mapping

from fcsweep.config.errors import ConfigError, ConfigProblems, is_whole, show_value
from fcsweep.model.coexistence import coexistence_problem
from fcsweep.model.confinement import boundary_problem
from fcsweep.model.integrators import DEFAULT_INTEGRATOR, integrator_problem
from fcsweep.model.parameters import core_exponent_problem
from fcsweep.model.shape import (MAX_DR_DT, MAX_STEP_PER_R0, MAX_STEP_PER_SPACING, contour_points_problem,  # noqa: F401
                                  dt_problem, step_problem, turn_problem)
from fcsweep.model.sizes import radius_bounds, size_problem

#: The size parameters, in the order :func:`fcsweep.model.sizes.radius_bounds` takes them.
SIZE_NAMES = ("size_distribution", "size_ratio", "size_fraction", "size_width")

if TYPE_CHECKING:
    from fcsweep.config.settings import RunSettings, SweepConfig

#: Runs of one sweep (grid points x replicates); expanding 10^5 runs takes seconds.
MAX_RUNS = 100_000
#: Steps of one run (the step counter and step * dt stay exact far beyond).
MAX_STEPS = 10**12
#: Frames of one trajectory.
MAX_FRAMES = 10**7
#: N x steps of one run: 10^14 cell-steps are ~3 CPU-years at 10^6 cell-steps/s.
MAX_CELL_STEPS = 10**14
#: Output paths: bytes of the whole path and of one component (Linux PATH_MAX, NAME_MAX).
MAX_PATH_BYTES, MAX_NAME_BYTES = 4095, 255
#: The step bounds (v0 dt, D_r dt) are the model's: :func:`fcsweep.model.shape.step_problem`.


def check_runnable(cfg: "SweepConfig") -> None:
    """Checks that concern running a sweep, not reading one: raise :class:`ConfigError`
    (all problems at once, the first grid point of each kind) if some grid point cannot
    be integrated faithfully.

    - K > 2M contour points (:func:`fcsweep.model.shape.contour_points_problem`);
    - dt within the tension limit of the stiffest shape mode
      (:func:`fcsweep.model.shape.max_stable_dt`);
    - quadrature and contour_points are not swept when every run has rigid discs;
    - the integrator runs with the quadrature and modes (:func:`fcsweep.model.integrators.integrator_problem`);
    - size differences start disordered under Euler (:func:`fcsweep.model.sizes.size_problem`); the
      dt limit uses the largest radius, the step bound the smallest (:func:`fcsweep.model.sizes.radius_bounds`);
    - a core exponent != 1 has the arc rule (or rigid discs) and Euler
      (:func:`fcsweep.model.parameters.core_exponent_problem`);
    - a well or channel starts disordered under Euler and holds its cells
      (:func:`fcsweep.model.confinement.boundary_problem`);
    - a coexistence start has room for a slab and a band (:func:`fcsweep.model.coexistence.coexistence_problem`);
    - step length and rotational step (:func:`check_step_sizes`);
    - the largest run fits in this machine's memory (:func:`check_memory`).

    ``validate``, ``simulate``, ``bench`` and :func:`fcsweep.sweep.executors.run_sweep`
    call it before anything runs; the read-only commands (status, list-runs, analyze,
    aggregate, plot) do not, so sweeps computed before a check existed stay readable.
    """
    grid, model = cfg.grid, cfg.model
    problems = ConfigProblems()

    def where(name):
        return f"grid.{name}" if name in grid else f"model.{name}"

    names = ("dt", "eta", "modes", "mu_shape", "R0", "contour_points") + SIZE_NAMES
    found = {"contour_points": False, "dt": False}
    for dt, eta, modes, mu_shape, R0, K, *sizes in _grid_or_model(cfg, names):
        R_max = radius_bounds(*sizes, R0=R0)[1]  # the largest cell has the stiffest modes
        for name, problem in (("contour_points", not found["contour_points"] and contour_points_problem(K, modes)),
                              ("dt", not found["dt"] and dt_problem(dt, eta, modes, mu_shape, R_max))):
            if problem:
                problems.add(ConfigError(f"{where(name)}: {problem}"))
                found[name] = True
        if all(found.values()):
            break
    for integrator, quadrature, modes in _grid_or_model(cfg, ("integrator", "quadrature", "modes")):
        problem = integrator_problem(integrator, quadrature, modes)
        if problem:
            problems.add(ConfigError(f"{where('integrator')}: {problem}"))
            break
    for core, quadrature, modes, integrator in _grid_or_model(cfg, ("core_exponent", "quadrature", "modes",
                                                                  "integrator")):
        problem = core_exponent_problem(core, quadrature, modes, integrator)
        if problem:
            problems.add(ConfigError(f"{where('core_exponent')}: {problem}"))
            break
    for distribution, initial, integrator, width, adhesion in _grid_or_model(
            cfg, ("size_distribution", "initial", "integrator", "size_width", "adhesion")):
        problem = size_problem(distribution, initial, integrator, width, adhesion)
        if problem:
            problems.add(ConfigError(f"{where('size_distribution')}: {problem}"))
            break
    for boundary, size, N, density, R0, initial, integrator, *sizes in _grid_or_model(
            cfg, ("boundary", "boundary_size", "N", "density", "R0", "initial", "integrator") + SIZE_NAMES):
        problem = boundary_problem(boundary, size, N, density, R0, radius_bounds(*sizes, R0=R0)[1], initial,
                                   integrator)
        if problem:
            problems.add(ConfigError(f"{where('boundary_size' if 'boundary_size' in problem else 'boundary')}: "
                                     f"{problem}"))
            break
    for N, initial in _grid_or_model(cfg, ("N", "initial")):
        problem = coexistence_problem(N, initial)
        if problem:
            problems.add(ConfigError(f"{where('N')}: {problem}"))
            break
    if set(grid.get("modes", (model.get("modes"),))) == {0}:
        for name in ("quadrature", "contour_points"):
            if name in grid:
                problems.add(ConfigError(
                    f"grid.{name} = {list(grid[name])!r} is swept but does not change the physics "
                    "with modes = 0 (rigid discs: exact lens overlaps, no contour); the runs would differ only in "
                    "their noise. Sweep it with modes >= 2 or remove it"))
    problems.attempt(check_step_sizes, cfg)
    problems.attempt(check_memory, cfg)
    problems.raise_if_any(cfg.source)


def _axis_length(name: str, spec) -> int:
    """Values a grid entry will have, without expanding it (0 if it is malformed:
    :func:`_grid_values` then says why)."""
    if isinstance(spec, Mapping):
        num = spec.get("num")
        if isinstance(num, float) and num.is_integer() and math.isfinite(num):
            num = int(num)
        return num if is_whole(num) and num > 0 else 0
    if isinstance(spec, (list, tuple)):
        return len(spec)
    return 1


def check_run_count(grid_in: Mapping, replicates: int) -> None:
    """Refuse a sweep of more than MAX_RUNS runs, counted before any grid is expanded."""
    lengths = {str(k): _axis_length(str(k), v) for k, v in grid_in.items()}
    allowed = f"at most {MAX_RUNS} runs (grid points x replicates)"
    for k, n in lengths.items():
        if n > MAX_RUNS:
            what = f"grid.{k}.num" if isinstance(grid_in[k], Mapping) else f"grid.{k}"
            raise ConfigError(f"{what} gives {n} values; a sweep has {allowed}")
    total = replicates * math.prod(max(n, 1) for n in lengths.values())
    if total > MAX_RUNS:
        shape = " x ".join(f"{k}[{n}]" for k, n in lengths.items())
        raise ConfigError(f"grid {shape} x replicates {replicates} = {total} runs; a sweep has {allowed}: "
                          "split it into several sweep files")


def check_run_length(run: RunSettings, grid: Mapping, model: Mapping) -> None:
    """Frames and cell-steps of one run within MAX_FRAMES and MAX_CELL_STEPS."""
    if run.n_frames > MAX_FRAMES:
        raise ConfigError(f"run.sample_every = {run.sample_every} gives {run.n_frames} frames of run.steps = "
                          f"{run.steps}; allowed at most {MAX_FRAMES} frames per run (sample less often)")
    n_max = max(grid["N"]) if "N" in grid else model["N"]
    if n_max * run.steps > MAX_CELL_STEPS:
        where = "grid.N" if "N" in grid else "model.N"
        raise ConfigError(f"run.steps = {run.steps} with {where} = {n_max} is {n_max * run.steps:.3g} cell-steps "
                          f"per run; allowed N x steps <= {MAX_CELL_STEPS:.0e} (about 3 CPU-years)")


def check_output_path(output: str) -> None:
    """Output paths that no file system can hold (NUL bytes, over-long names)."""
    if "\0" in output:
        raise ConfigError(f"output = {show_value(output)} contains a NUL character; no file system allows it")
    raw = os.fsencode(output)
    if len(raw) > MAX_PATH_BYTES:
        raise ConfigError(f"output = {show_value(output)} is {len(raw)} bytes long; allowed at most {MAX_PATH_BYTES}")
    for part in raw.split(b"/"):
        if len(part) > MAX_NAME_BYTES:
            raise ConfigError(f"output = {show_value(output)} has a {len(part)}-byte component; allowed at most "
                              f"{MAX_NAME_BYTES} bytes per directory name")


def _grid_or_model(cfg: "SweepConfig", names) -> itertools.product:
    """Every combination of the named parameters over the grid (at most MAX_RUNS)."""
    return itertools.product(*(cfg.grid[n] if n in cfg.grid else (cfg.model[n],) for n in names))


def check_step_sizes(cfg: "SweepConfig") -> None:
    """Refuse grid points whose step moves a cell too far or turns it too much (the model's
    rules :func:`fcsweep.model.shape.step_problem` and :func:`~fcsweep.model.shape.turn_problem`,
    which :class:`fcsweep.simulation.SimParams` checks too).  Both are reported together,
    each at the first grid point that breaks it.
    """
    def where(name):
        return f"grid.{name}" if name in cfg.grid else f"model.{name}"

    step = turn = ""  # the first grid point of each kind: a message per kind, not per point
    for v0, Dr, dt, R0, K, modes, *sizes in _grid_or_model(cfg, ("v0", "Dr", "dt", "R0", "contour_points", "modes")
                                                           + SIZE_NAMES):
        R0 = radius_bounds(*sizes, R0=R0)[0]  # the smallest cell has the finest contour spacing
        step = step or step_problem(v0, dt, R0, K, modes, key=where("v0"))
        turn = turn or turn_problem(Dr, dt, key=where("Dr"))
        if step and turn:
            break
    if step or turn:
        raise ConfigError(problems=[p for p in (step, turn) if p])


def run_memory_bytes(N: int, contour_points: int, modes: int, quadrature: str = "arc",
                     integrator: str = DEFAULT_INTEGRATOR) -> int:
    """Estimated memory of one run's simulation (bytes): the per-cell work arrays of the
    kernels (contour samples, tangents and weights, 2K + 5 (2K + 4) doubles per cell; the
    neighbour list; the arc rule's pair buffer, and contact-jacobi's per-pair shares and
    records) plus the state and one frame buffer of the sweep runner (64 MiB)."""
    K, M1 = int(contour_points), max(int(modes) - 1, 0)
    per_cell = 2 * K + 5 * (2 * K + 4) + 5 + (4 + 2 * M1) + 3 + (3 + 2 * M1) + 1 + 2 * 16 + 4 + 2 * (5 + 2 * M1)
    if quadrature == "arc":
        per_cell += 16 * (4 + 2 * M1) + 16  # pair buffer and back index
        if integrator == "contact-jacobi":
            per_cell += 16 * (4 + 2 * M1 + 6)  # 6 = the columns of kernels.contacts' pair record
    return 8 * int(N) * per_cell + (64 << 20)


def machine_memory_bytes() -> int | None:
    """Physical memory of this machine, or the cgroup's limit if lower (``None``: unknown)."""
    try:
        total = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        total = None
    for limit_file in ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"):
        try:
            text = Path(limit_file).read_text().strip()
        except OSError:
            continue
        if text.isdigit() and (total is None or int(text) < total):
            total = int(text)
        break
    return total


def check_memory(cfg: "SweepConfig", available: int | None = None) -> None:
    """Refuse a sweep whose largest run needs more memory than this machine has
    (``available``: bytes, default :func:`machine_memory_bytes`)."""
    available = machine_memory_bytes() if available is None else available
    if not available:
        return
    combos = _grid_or_model(cfg, ("N", "contour_points", "modes", "quadrature", "integrator"))
    need, worst = max((run_memory_bytes(*c), c) for c in combos)
    if need > available:
        N, K, modes, quad, _ = worst
        key = next((f"grid.{k}" for k in ("N", "contour_points") if k in cfg.grid), "model.N")
        raise ConfigError(f"{key}: a run with N = {N}, contour_points = {K}, modes = {modes} ({quad}) needs about "
                          f"{need / 2**30:.1f} GiB of memory; this machine has {available / 2**30:.1f} GiB")
