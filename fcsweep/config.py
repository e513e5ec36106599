"""Sweep configuration: YAML -> validated, frozen run specifications.

A sweep file has six top-level sections (see ``results_schema.md`` and the README)::

    output: runs/phase            # or {dir: runs/phase, fields: [...], compression: gzip}
    seed: 12345
    replicates: 1
    grid: {eta: [0.01, 0.1], v0: {start: 0.01, stop: 0.06, num: 6}, N: [1024]}
    model: {density: 0.95, Dr: 0.01, dt: 0.005, modes: 6, contour_points: 40}
    run: {steps: 1000000, sample_every: 1000, checkpoint_every: 100000, transient: 0.2,
          until: {check_every: 100000, min_steps: 200000, confidence: 0.95}}   # until optional

Everything is validated before anything runs; every problem raises :class:`ConfigError`
whose message names the key, the offending value and what is allowed.

Run identity
------------
Each grid point x replicate is a run.  Its id is the first 12 hex digits of the SHA-256 of
the canonical JSON ``{"params": {...}, "replicate": r}``, where ``params`` holds every model
parameter (grid and fixed values, defaults filled in) with floats written as
``repr(float(x))`` and the integer parameters (N, modes, contour_points) as ints, keys
sorted (``integrator`` only when it is not the default ``euler``, so ids from before
the key existed are unchanged).  So ``eta: 1`` and ``eta: 1.0`` give the same run.  The
run's seed is ``SeedSequence([seed, int(run_id, 16)]).generate_state(1, uint64)[0] >> 1`` (a
deterministic 63-bit integer), so every run has independent noise and the same run always
gets the same noise.

The run length (``run.steps``, ``run.until``) is not part of the id: raising the step
count continues a finished run instead of recomputing it (see
:func:`fcsweep.sweep.runner.fingerprint_of`).  Grid points added by ``fcsweep refine``
are read from ``<output>/refinement.json`` (:mod:`fcsweep.io.refinement`) and follow the
product grid's runs, so existing run indices never change.

Ranges ``{start, stop, num}`` expand with ``numpy.linspace`` (``log: true``:
``numpy.geomspace``) and each value is rounded to 12 significant digits, so a range and
the equivalent list give the same runs.
"""

from __future__ import annotations

import dataclasses
import difflib
import hashlib
import itertools
import json
import math
import os
import re
import reprlib
import stat
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

import numpy as np
import yaml

from fcsweep.model.integrators import DEFAULT_INTEGRATOR, INTEGRATORS, integrator_problem
from fcsweep.model.rates import QUADRATURES
from fcsweep.model.shape import contour_points_problem, dt_problem

__all__ = [
    "ConfigError",
    "SweepConfig",
    "RunSpec",
    "RunSettings",
    "UntilSettings",
    "UNTIL_OBSERVABLES",
    "StoreSettings",
    "MODEL_DEFAULTS",
    "FIELDS",
    "load_config",
    "check_runnable",
    "parse_config",
    "run_id_of",
    "seed_of",
    "builtin_demo_path",
    "PARAM_RANGES",
    "MAX_RUNS",
    "check_step_sizes",
    "check_memory",
    "run_memory_bytes",
    "machine_memory_bytes",
]


class ConfigError(ValueError):
    """An invalid sweep configuration; the message names key, value and what is allowed.

    The message is always one line (line breaks of quoted parser messages are folded).
    """

    def __init__(self, message: str):
        super().__init__(re.sub(r"\s*[\r\n]+\s*", " ", str(message)).strip())


#: Model parameters and their defaults (docs/model.md); ``None`` means "must be given".
MODEL_DEFAULTS: dict[str, Any] = {
    "N": None,
    "eta": None,
    "v0": None,
    "Dr": 0.01,
    "density": 0.95,
    "dt": 5e-3,
    "contour_points": 40,
    "modes": 6,
    "quadrature": "arc",
    "R0": 1.0,
    "mu_theta": 1.0,
    "mu_shape": 1.0,
    "integrator": DEFAULT_INTEGRATOR,
}
INT_PARAMS = ("N", "modes", "contour_points")
#: String parameters and their allowed values.
STR_PARAMS = {"quadrature": QUADRATURES, "integrator": INTEGRATORS}

#: Per-cell time series that ``output.fields`` may select (position and image always stored).
FIELDS = ("position", "image", "theta", "shape_a", "shape_b")
DEFAULT_FIELDS = FIELDS
COMPRESSIONS = ("gzip", "lzf", "none")

TOP_KEYS = ("output", "seed", "replicates", "grid", "model", "run", "description")
RUN_KEYS = ("steps", "sample_every", "checkpoint_every", "transient", "until")
UNTIL_KEYS = ("check_every", "min_steps", "confidence", "rel_error")
#: Observables ``run.until.rel_error`` may target: scalars of the analysis that carry a
#: 1-sigma error ``<name>_err`` (:data:`fcsweep.analysis.pipeline.SCALARS`).
UNTIL_OBSERVABLES = ("D_eff", "D_s", "q_mean", "q_frac_above", "rho_d", "largest_cluster_fraction", "psi6")
#: Default ``run.until.confidence``: both labels at 95 % probability.
UNTIL_CONFIDENCE = 0.95
OUTPUT_KEYS = ("dir", "fields", "compression", "compression_level")
RANGE_KEYS = ("start", "stop", "num", "log")


@dataclass(frozen=True)
class UntilSettings:
    """When a run may stop before ``run.steps`` (the cap): its answer is settled.

    At every step that is a multiple of ``check_every`` and at least ``min_steps`` (and
    at the cap) the run analyses its own frames; it stops when the phase and percolation
    labels are determined with probability >= ``confidence`` and every observable of
    ``rel_error`` has ``err <= rel_error[name] * |value|``.
    """

    check_every: int
    min_steps: int
    confidence: float = UNTIL_CONFIDENCE
    rel_error: tuple[tuple[str, float], ...] = ()

    def as_dict(self) -> dict[str, Any]:
        """Plain dict (``rel_error`` as a mapping), as written into status and trajectory files."""
        return {"check_every": self.check_every, "min_steps": self.min_steps,
                "confidence": self.confidence, "rel_error": dict(self.rel_error)}

    def is_check_step(self, step: int, cap: int) -> bool:
        """Whether a run checks itself at ``step`` (a check step or the cap, past ``min_steps``)."""
        return step > 0 and step >= self.min_steps and (step % self.check_every == 0 or step == cap)


@dataclass(frozen=True)
class RunSettings:
    """Integration length and output cadence shared by every run of a sweep.

    ``steps`` is the length of every run, or its cap when ``until`` is given.
    """

    steps: int
    sample_every: int
    checkpoint_every: int
    transient: float = 0.2
    until: UntilSettings | None = None

    @property
    def n_frames(self) -> int:
        """Frames per trajectory: steps 0, sample_every, ..., steps."""
        return self.steps // self.sample_every + 1


@dataclass(frozen=True)
class StoreSettings:
    """What the trajectory file stores and how it is compressed."""

    fields: tuple[str, ...] = DEFAULT_FIELDS
    compression: str = "gzip"
    compression_level: int = 4


@dataclass(frozen=True)
class RunSpec:
    """One run: a grid point and a replicate.

    Attributes
    ----------
    index : int
        Position in the sweep (0-based; the ``--task-index`` of job arrays).
    run_id : str
        12 hex digits, a hash of the canonical parameters and the replicate.
    params : dict
        Every model parameter (N, eta, v0, Dr, ...) plus ``seed``.
    replicate : int
    swept : tuple of str
        Names of the swept parameters, in grid order.
    """

    index: int
    run_id: str
    params: Mapping[str, Any]
    replicate: int
    swept: tuple[str, ...]

    @property
    def seed(self) -> int:
        return int(self.params["seed"])

    def model_params(self) -> dict[str, Any]:
        """Keyword arguments of :meth:`Simulation.from_lattice` (without ``N``)."""
        return {k: v for k, v in self.params.items() if k != "N"}

    def label(self) -> str:
        """Short human label: swept parameter values and replicate."""
        parts = [f"{k}={self.params[k]}" for k in self.swept]
        if self.replicate:
            parts.append(f"rep={self.replicate}")
        return " ".join(parts)


@dataclass(frozen=True)
class SweepConfig:
    """A validated sweep.

    Attributes
    ----------
    output : Path
        Sweep directory (relative paths resolve against the working directory).
    log_axes : tuple of str
        Swept parameters given as ``{..., log: true}`` ranges (``fcsweep refine`` bisects
        them geometrically).
    seed : int
        Base seed.
    replicates : int
    grid : dict
        Swept parameter -> tuple of values (grid order kept).
    model : dict
        Fixed model parameters with defaults filled in (swept ones excluded).
    run : RunSettings
    store : StoreSettings
    source : str
        Path of the YAML file, or ``"<string>"``.
    """

    output: Path
    seed: int
    replicates: int
    grid: Mapping[str, tuple]
    model: Mapping[str, Any]
    run: RunSettings
    store: StoreSettings = field(default_factory=StoreSettings)
    description: str = ""
    source: str = "<string>"
    log_axes: tuple[str, ...] = ()

    @property
    def swept(self) -> list[str]:
        """Swept parameter names in grid order."""
        return list(self.grid)

    def runs(self) -> list[RunSpec]:
        """All runs: grid points in grid order (last key fastest), replicates innermost,
        then the points ``fcsweep refine`` added (``<output>/refinement.json``) in the
        order they were added.

        Raises
        ------
        ConfigError
            If the refinement file does not fit this grid.
        """
        return _expand(self)

    def run_dir(self, run_id: str) -> Path:
        """Directory of one run: ``output / "runs" / run_id``."""
        return self.output / "runs" / run_id

    def with_output(self, output: str | os.PathLike) -> "SweepConfig":
        """Copy of this config writing to another directory (ids are unchanged)."""
        return dataclasses.replace(self, output=Path(output))

    def to_dict(self) -> dict[str, Any]:
        """JSON-able dict of the validated config (what trajectory files record)."""
        return {
            "output": str(self.output),
            "seed": self.seed,
            "replicates": self.replicates,
            "grid": {k: list(v) for k, v in self.grid.items()},
            "model": dict(self.model),
            "run": {**dataclasses.asdict(self.run),
                    "until": self.run.until.as_dict() if self.run.until else None},
            "store": {**dataclasses.asdict(self.store), "fields": list(self.store.fields)},
            "description": self.description,
        }


# ----------------------------------------------------------------------------- loading


class _UniqueKeyLoader(yaml.SafeLoader):
    """SafeLoader that rejects duplicate mapping keys instead of keeping the last."""


def _construct_mapping(loader, node, deep=False):
    seen = set()
    for key_node, _ in node.value:
        key = loader.construct_object(key_node, deep=deep)
        try:
            hash(key)
        except TypeError:
            raise ConfigError(
                f"complex key {_source_text(key_node)} "
                f"(line {key_node.start_mark.line + 1}); "
                "keys must be plain names, not lists or mappings"
            ) from None
        if key in seen:
            raise ConfigError(
                f"duplicate key {_show(key)} (line {key_node.start_mark.line + 1}); "
                "each key may appear once per section"
            )
        seen.add(key)
    return yaml.SafeLoader.construct_mapping(loader, node, deep=deep)


def _source_text(node) -> str:
    """The YAML text of a node, on one line and cut short."""
    start, end = node.start_mark, node.end_mark
    text = " ".join(str(start.buffer or "")[start.index:end.index].split())
    return text if len(text) <= 60 else text[:57] + "..."


_UniqueKeyLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_mapping)


def _construct_int(loader, node):
    try:
        return yaml.SafeLoader.construct_yaml_int(loader, node)
    except ValueError:  # more digits than int() converts (sys.get_int_max_str_digits)
        raise ConfigError(f"the integer at line {node.start_mark.line + 1} has {len(node.value)} digits; "
                          "no setting takes more than 20") from None


_UniqueKeyLoader.add_constructor("tag:yaml.org,2002:int", _construct_int)


def builtin_demo_path() -> Path:
    """Path of the built-in demo sweep shipped with the package (``fcsweep/data/smoke.yaml``)."""
    from importlib.resources import files

    return Path(str(files("fcsweep") / "data" / "smoke.yaml"))


def load_config(path: str | os.PathLike) -> SweepConfig:
    """Read and validate a sweep YAML file.

    Raises
    ------
    ConfigError
        If the file is missing, not YAML, or any value is invalid.
    """
    path = Path(path)
    return parse_config(_read_text(path), source=str(path))


def parse_config(text: str, source: str = "<string>") -> SweepConfig:
    """Validate a sweep given as YAML text. See :func:`load_config`."""
    if len(text) > MAX_CONFIG_BYTES:
        raise ConfigError(f"{source}: {len(text)} characters; a sweep file has at most {MAX_CONFIG_BYTES}")
    try:
        data = yaml.load(text, Loader=_UniqueKeyLoader)
    except ConfigError as exc:
        raise ConfigError(f"{source}: {exc}") from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        problem = getattr(exc, "problem", None) or str(exc)
        raise ConfigError(f"{source}: not valid YAML{where}: {problem}") from None
    except RecursionError:
        raise ConfigError(f"{source}: brackets or indentation nested too deeply to be a sweep file "
                          f"(at most {MAX_NESTING} levels)") from None
    except (ValueError, TypeError, OverflowError) as exc:  # e.g. an integer of more than 4300 digits
        raise ConfigError(f"{source}: not a valid sweep file: {exc}") from None
    try:
        _check_structure(data)
        return _validate(data, source)
    except ConfigError as exc:
        raise ConfigError(f"{source}: {exc}") from None
    except (ArithmeticError, TypeError, ValueError, RecursionError) as exc:  # a check missed: still no traceback
        raise ConfigError(f"{source}: {UNCHECKED} ({type(exc).__name__}: {exc})") from None


# -------------------------------------------------------------------------- validation


def _unknown(key: str, allowed, where: str) -> ConfigError:
    close = difflib.get_close_matches(str(key), list(allowed), n=1, cutoff=0.6)
    if not close:
        close = [a for a in allowed if str(a).lower() == str(key).lower()]
    hint = f"; did you mean {close[0]!r}?" if close else ""
    return ConfigError(
        f"unknown key {where}{_show(key)}{hint} (allowed: {', '.join(map(str, allowed))})"
    )


def _check_keys(d: Mapping, allowed, where: str) -> None:
    for k in d:
        if k not in allowed:
            raise _unknown(k, allowed, where)


def _is_int(x) -> bool:
    return isinstance(x, (int, np.integer)) and not isinstance(x, bool)


def _is_real(x) -> bool:
    return isinstance(x, (int, float, np.integer, np.floating)) and not isinstance(x, bool)


def _int(value, key: str, *, minimum: int | None = None, maximum: int | None = None) -> int:
    if isinstance(value, float) and value.is_integer() and abs(value) < 2**53:
        value = int(value)
    if maximum is not None and _is_real(value) and value > maximum:  # also 1e30, before int() of it
        low = f"{minimum} <= " if minimum is not None else ""
        raise ConfigError(f"{key} = {_show(value)} is out of range; allowed {low}{key.rsplit('.', 1)[-1]} <= "
                          f"{maximum}")
    if not _is_int(value):
        raise ConfigError(f"{key} = {_show(value)} must be an integer")
    value = int(value)
    if minimum is not None and value < minimum:
        raise ConfigError(f"{key} = {value} must be an integer >= {minimum}")
    return value


def _real(value, key: str) -> float:
    if not _is_real(value):
        raise ConfigError(f"{key} = {_show(value)} must be a number")
    try:
        value = float(value)
    except OverflowError:  # an int beyond float range
        raise ConfigError(f"{key} = {_show(value)} must be a finite number") from None
    if not math.isfinite(value):
        raise ConfigError(f"{key} = {value!r} must be a finite number")
    return value


def _check_param(name: str, value, where: str) -> Any:
    """Validate and canonicalise one model parameter value."""
    key = f"{where}.{name}"
    if name in STR_PARAMS:
        if not isinstance(value, str) or value not in STR_PARAMS[name]:
            raise ConfigError(f"{key} = {_show(value)} is not allowed; choose one of {list(STR_PARAMS[name])}")
        return value
    if name == "N":
        n = _int(value, key, minimum=4, maximum=PARAM_RANGES["N"][1])
        from fcsweep.model.lattice import lattice_side

        try:
            lattice_side(n)
        except ValueError as exc:
            raise ConfigError(f"{key} = {value!r}: {exc}") from None
        return n
    if name == "modes":
        m = _int(value, key, minimum=0)
        if m == 1 or m > 32:
            raise ConfigError(f"{key} = {m} is not allowed; modes is 0 (rigid discs) or 2..32")
        return m
    if name == "contour_points":
        return _int(value, key, minimum=8, maximum=PARAM_RANGES["contour_points"][1])
    x = _real(value, key)
    if name in ("eta", "v0", "Dr") and x < 0:
        raise ConfigError(f"{key} = {value!r} is out of range; {name} must be >= 0")
    if name in ("mu_theta", "mu_shape") and x < 0:
        raise ConfigError(f"{key} = {value!r} is out of range; {name} must be >= 0")
    if name == "density" and not 0.0 < x < 1.0:
        raise ConfigError(f"{key} = {value!r} is out of range; density must lie in (0, 1)")
    if name in ("dt", "R0") and x <= 0:
        raise ConfigError(f"{key} = {value!r} is out of range; {name} must be > 0")
    return _check_range(name, x, key)


def _grid_values(name: str, spec) -> tuple:
    key = f"grid.{name}"
    if isinstance(spec, Mapping):
        _check_keys(spec, RANGE_KEYS, f"in {key}: ")
        missing = [k for k in ("start", "stop", "num") if k not in spec]
        if missing:
            raise ConfigError(
                f"{key} = {_show(dict(spec))} is missing {missing}; a range is {{start, stop, num[, log]}}"
            )
        start = _real(spec["start"], f"{key}.start")
        stop = _real(spec["stop"], f"{key}.stop")
        num = _int(spec["num"], f"{key}.num", minimum=1, maximum=MAX_RUNS)
        log = spec.get("log", False)
        if not isinstance(log, bool):
            raise ConfigError(f"{key}.log = {_show(log)} must be true or false")
        if name in STR_PARAMS:
            raise ConfigError(f"{key} = {_show(dict(spec))}: {name} takes a list of names, not a range")
        if log:
            if start <= 0 or stop <= 0:
                raise ConfigError(f"{key} = {_show(dict(spec))}: a log range needs start > 0 and stop > 0")
            values = np.geomspace(start, stop, num)
        else:
            values = np.linspace(start, stop, num)
        # 12 significant digits: linspace(0.01, 0.06, 6) gives 0.03, not 0.030000000000000002
        values = [float(f"{v:.12g}") for v in values]
        if name in INT_PARAMS:
            if any(not float(v).is_integer() for v in values):
                raise ConfigError(
                    f"{key} = {_show(dict(spec))} gives non-integer values {values}; "
                    f"{name} must be integers (use a list)"
                )
            values = [int(v) for v in values]
    elif isinstance(spec, (list, tuple)):
        if len(spec) == 0:
            raise ConfigError(f"{key} = [] is empty; give at least one value")
        values = list(spec)
    elif isinstance(spec, (str, int, float)) and not isinstance(spec, bool):
        values = [spec]
    else:
        raise ConfigError(f"{key} = {_show(spec)} must be a list of values or {{start, stop, num}}")
    out = tuple(_check_param(name, v, "grid") for v in values)
    canon = Counter(_canon_value(name, v) for v in out)
    if len(canon) != len(out):
        dup = next(c for c, n in canon.items() if n > 1)
        raise ConfigError(f"{key} = {_show(list(values))} repeats the value {dup}; each value once")
    return out


def check_runnable(cfg: "SweepConfig") -> None:
    """Checks that concern running a sweep, not reading one: raise :class:`ConfigError`
    if some grid point cannot be integrated faithfully.

    - K > 2M contour points (:func:`fcsweep.model.shape.contour_points_problem`);
    - dt within the tension limit of the stiffest shape mode
      (:func:`fcsweep.model.shape.max_stable_dt`);
    - quadrature and contour_points are not swept when every run has rigid discs;
    - the integrator runs with the quadrature and modes (:func:`fcsweep.model.integrators.integrator_problem`);
    - step length and rotational step (:func:`check_step_sizes`);
    - the largest run fits in this machine's memory (:func:`check_memory`).

    ``validate``, ``simulate``, ``bench`` and :func:`fcsweep.sweep.executors.run_sweep`
    call it before anything runs; the read-only commands (status, list-runs, analyze,
    aggregate, plot) do not, so sweeps computed before a check existed stay readable.
    """
    grid, model = cfg.grid, cfg.model

    def where(name):
        return f"grid.{name}" if name in grid else f"model.{name}"

    names = ("dt", "eta", "modes", "mu_shape", "R0", "contour_points")
    for dt, eta, modes, mu_shape, R0, K in _grid_or_model(cfg, names):
        problem = contour_points_problem(K, modes)
        if problem:
            raise ConfigError(f"{cfg.source}: {where('contour_points')}: {problem}")
        problem = dt_problem(dt, eta, modes, mu_shape, R0)
        if problem:
            raise ConfigError(f"{cfg.source}: {where('dt')}: {problem}")
    for integrator, quadrature, modes in _grid_or_model(cfg, ("integrator", "quadrature", "modes")):
        problem = integrator_problem(integrator, quadrature, modes)
        if problem:
            raise ConfigError(f"{cfg.source}: {where('integrator')}: {problem}")
    if set(grid.get("modes", (model.get("modes"),))) == {0}:
        for name in ("quadrature", "contour_points"):
            if name in grid:
                raise ConfigError(
                    f"{cfg.source}: grid.{name} = {list(grid[name])!r} is swept but does not change the physics "
                    "with modes = 0 (rigid discs: exact lens overlaps, no contour); the runs would differ only in "
                    "their noise. Sweep it with modes >= 2 or remove it")
    try:
        check_step_sizes(cfg)
        check_memory(cfg)
    except ConfigError as exc:
        raise ConfigError(f"{cfg.source}: {exc}") from None


def _validate(data, source: str) -> SweepConfig:
    if data is None:
        raise ConfigError("the file is empty; a sweep needs at least 'grid' and 'run'")
    if not isinstance(data, Mapping):
        raise ConfigError(f"top level must be a mapping of sections, got {type(data).__name__}")
    _check_keys(data, TOP_KEYS, "")
    for req in ("output", "grid", "run"):
        if req not in data:
            raise ConfigError(f"missing required section {req!r}")

    # output
    out = data["output"]
    store = StoreSettings()
    if isinstance(out, Mapping):
        _check_keys(out, OUTPUT_KEYS, "in output: ")
        if "dir" not in out:
            raise ConfigError("output.dir is missing; give the sweep directory")
        fields = out.get("fields", list(DEFAULT_FIELDS))
        if not isinstance(fields, (list, tuple)) or not all(isinstance(f, str) for f in fields):
            raise ConfigError(f"output.fields = {_show(fields)} must be a list of names from {list(FIELDS)}")
        for f in fields:
            if f not in FIELDS:
                raise _unknown(f, FIELDS, "in output.fields: ")
        fields = tuple(f for f in FIELDS if f in set(fields) | {"position", "image"})
        comp = out.get("compression", "gzip")
        if comp not in COMPRESSIONS:
            raise ConfigError(f"output.compression = {_show(comp)} is not allowed; choose one of {list(COMPRESSIONS)}")
        level = _int(out.get("compression_level", 4), "output.compression_level", minimum=0)
        if level > 9:
            raise ConfigError(f"output.compression_level = {level} is out of range; allowed 0..9")
        store = StoreSettings(fields=fields, compression=comp, compression_level=level)
        out = out["dir"]
    if not isinstance(out, str) or not out.strip():
        raise ConfigError(f"output = {_show(out)} must be a directory path (string)")
    _check_output_path(out)
    output = Path(os.path.expanduser(out))

    seed = _int(data.get("seed", 0), "seed", minimum=0)
    if seed >= 2**63:
        raise ConfigError(f"seed = {seed} is out of range; allowed 0 <= seed < 2**63")
    replicates = _int(data.get("replicates", 1), "replicates", minimum=1, maximum=MAX_RUNS)
    description = data.get("description", "")
    if not isinstance(description, str):
        raise ConfigError(f"description = {_show(description)} must be a string")

    # grid
    grid_in = data["grid"]
    if not isinstance(grid_in, Mapping):
        raise ConfigError(f"grid = {_show(grid_in)} must be a mapping of parameter -> values")
    if len(grid_in) == 0:
        raise ConfigError("grid = {} is empty; sweep at least one model parameter")
    _check_keys(grid_in, list(MODEL_DEFAULTS), "in grid: ")
    _check_run_count(grid_in, replicates)
    grid = {str(k): _grid_values(str(k), v) for k, v in grid_in.items()}
    log_axes = tuple(str(k) for k, v in grid_in.items() if isinstance(v, Mapping) and v.get("log") is True)

    # model
    model_in = data.get("model") or {}
    if not isinstance(model_in, Mapping):
        raise ConfigError(f"model = {_show(model_in)} must be a mapping of parameter -> value")
    _check_keys(model_in, list(MODEL_DEFAULTS), "in model: ")
    model: dict[str, Any] = {}
    for name, default in MODEL_DEFAULTS.items():
        if name in grid:
            if name in model_in:
                raise ConfigError(
                    f"model.{name} = {_show(model_in[name])} is also swept in grid.{name}; "
                    "give it in one place only"
                )
            continue
        if name in model_in:
            model[name] = _check_param(name, model_in[name], "model")
        elif default is None:
            raise ConfigError(f"model parameter {name!r} is missing; give it in 'model' or 'grid'")
        else:
            model[name] = default

    # run
    run_in = data["run"]
    if not isinstance(run_in, Mapping):
        raise ConfigError(f"run = {_show(run_in)} must be a mapping")
    _check_keys(run_in, RUN_KEYS, "in run: ")
    for req in ("steps", "sample_every"):
        if req not in run_in:
            raise ConfigError(f"run.{req} is missing")
    steps = _int(run_in["steps"], "run.steps", minimum=1, maximum=MAX_STEPS)
    sample_every = _int(run_in["sample_every"], "run.sample_every", minimum=1, maximum=MAX_STEPS)
    if steps % sample_every:
        raise ConfigError(
            f"run.steps = {steps} is not a multiple of run.sample_every = {sample_every}; "
            "steps must be a whole number of frames"
        )
    checkpoint_every = _int(run_in.get("checkpoint_every", steps), "run.checkpoint_every", minimum=1,
                            maximum=MAX_STEPS)
    if checkpoint_every % sample_every:
        raise ConfigError(
            f"run.checkpoint_every = {checkpoint_every} is not a multiple of run.sample_every = "
            f"{sample_every}; checkpoints are taken on frame boundaries"
        )
    transient = _real(run_in.get("transient", 0.2), "run.transient")
    if not 0.0 <= transient < 1.0:
        raise ConfigError(f"run.transient = {transient!r} is out of range; allowed 0 <= transient < 1")
    until = _until(run_in["until"], steps, sample_every, checkpoint_every) if run_in.get("until") is not None \
        else None
    run = RunSettings(steps, sample_every, checkpoint_every, transient, until)
    _check_run_length(run, grid, model)

    return SweepConfig(
        output=output,
        seed=seed,
        replicates=replicates,
        grid=grid,
        model=model,
        run=run,
        store=store,
        description=description,
        source=source,
        log_axes=log_axes,
    )


def _until(until_in, steps: int, sample_every: int, checkpoint_every: int) -> UntilSettings:
    """Validate ``run.until``; every message names the key and its allowed range."""
    if not isinstance(until_in, Mapping):
        raise ConfigError(f"run.until = {until_in!r} must be a mapping with keys {', '.join(UNTIL_KEYS)}")
    _check_keys(until_in, UNTIL_KEYS, "in run.until: ")
    if "check_every" not in until_in:
        raise ConfigError(f"run.until.check_every is missing; give the steps between checks, a multiple of "
                          f"run.checkpoint_every = {checkpoint_every} and at most run.steps = {steps}")
    check_every = _int(until_in["check_every"], "run.until.check_every", minimum=1)
    if check_every % checkpoint_every or check_every > steps:
        raise ConfigError(
            f"run.until.check_every = {check_every} is not allowed; it must be a multiple of "
            f"run.checkpoint_every = {checkpoint_every} (checks happen at checkpoints) and at most "
            f"run.steps = {steps}")
    min_steps = _int(until_in.get("min_steps", check_every), "run.until.min_steps", minimum=0)
    if min_steps > steps:
        raise ConfigError(f"run.until.min_steps = {min_steps} is out of range; allowed 0 <= min_steps <= "
                          f"run.steps = {steps}")
    confidence = _real(until_in.get("confidence", UNTIL_CONFIDENCE), "run.until.confidence")
    if not 0.5 <= confidence < 1.0:
        raise ConfigError(f"run.until.confidence = {confidence!r} is out of range; allowed 0.5 <= confidence < 1 "
                          "(the probability both labels must reach)")
    rel_in = until_in.get("rel_error") or {}
    if not isinstance(rel_in, Mapping):
        raise ConfigError(f"run.until.rel_error = {rel_in!r} must be a mapping observable -> target, "
                          f"observables from {list(UNTIL_OBSERVABLES)}")
    _check_keys(rel_in, UNTIL_OBSERVABLES, "in run.until.rel_error: ")
    rel = []
    for name in UNTIL_OBSERVABLES:
        if name in rel_in:
            x = _real(rel_in[name], f"run.until.rel_error.{name}")
            if not 0.0 < x <= 1.0:
                raise ConfigError(f"run.until.rel_error.{name} = {x!r} is out of range; allowed 0 < target <= 1 "
                                  "(1-sigma error / |value|)")
            rel.append((name, x))
    return UntilSettings(check_every, min_steps, confidence, tuple(rel))


# ------------------------------------------------ resource bounds and physical ranges
#
# Limits that keep every command fast and bounded in memory whatever a file says (runs
# are counted arithmetically before any grid is expanded), and that keep the integration
# faithful.  configs/README.md ("Allowed ranges") documents each of them.

#: A sweep file is at most this large (bytes) ...
MAX_CONFIG_BYTES = 1 << 20
#: ... nests at most this deep (a sweep needs 4 levels: top, grid, key, range) ...
MAX_NESTING = 16
#: ... and holds at most this many values once YAML aliases are expanded.
MAX_VALUES = 200_000
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
#: Largest step length v0 dt as a fraction of the contour spacing 2 pi R0 / K ...
MAX_STEP_PER_SPACING = 0.5
#: ... and in units of R0 whatever K (rigid discs have no contour).
MAX_STEP_PER_R0 = 0.1
#: Largest D_r dt: the discrete walk has D = D0 (D_r dt / 2) coth(D_r dt / 2) = D0 (1 + (D_r dt)^2/12 + ...).
MAX_DR_DT = 0.1

#: Closed ranges of the model parameters (density: lo <= rho < 1).  The lower bounds of
#: density and dt catch underflowed values (1e-320): at density 1e-6 the lattice constant
#: is already ~1900 R0, and dt 1e-6 is 5000 x below the paper's step.
PARAM_RANGES: dict[str, tuple[float, float]] = {
    "N": (4, 10**6),
    "eta": (0.0, 1e3),
    "v0": (0.0, 1e3),
    "Dr": (0.0, 1e3),
    "density": (1e-6, 1.0),
    "dt": (1e-6, 1.0),
    "contour_points": (8, 4096),
    "modes": (0, 32),
    "R0": (1e-3, 1e3),
    "mu_theta": (0.0, 1e3),
    "mu_shape": (0.0, 1e3),
}

#: Message of the safety net in :func:`parse_config` (tests assert it never appears).
UNCHECKED = "a value no check anticipated"

_REPR = reprlib.Repr()
_REPR.maxstring = _REPR.maxother = 60
_REPR.maxlist = _REPR.maxdict = _REPR.maxset = _REPR.maxtuple = 8
_REPR.maxlevel = 3


def _show(value) -> str:
    """``repr`` cut to one short line (values may be huge or deeply nested)."""
    try:
        return _REPR.repr(value)
    except (ValueError, RecursionError):  # e.g. an int beyond str()'s digit limit
        return f"<{type(value).__name__}>"


def _read_text(path: Path) -> str:
    """The text of a sweep file: a regular file of at most MAX_CONFIG_BYTES of UTF-8."""
    try:
        st = path.stat()
        if not stat.S_ISREG(st.st_mode):
            kind = "a directory" if stat.S_ISDIR(st.st_mode) else "not a regular file"
            raise ConfigError(f"config file {str(path)!r} is {kind}")
        if st.st_size > MAX_CONFIG_BYTES:
            raise ConfigError(f"config file {str(path)!r} has {st.st_size} bytes; a sweep file has at most "
                              f"{MAX_CONFIG_BYTES}")
        with open(path, "rb") as fh:
            raw = fh.read(MAX_CONFIG_BYTES + 1)
    except OSError as exc:
        raise ConfigError(f"cannot read config file {str(path)!r}: {exc.strerror or exc}") from None
    except ValueError as exc:  # e.g. a NUL byte in the path
        raise ConfigError(f"cannot read config file {str(path)!r}: {exc}") from None
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw[:exc.start].count(b"\n") + 1
        raise ConfigError(f"{path}: not UTF-8 text: byte 0x{raw[exc.start]:02x} at line {line} "
                          f"(offset {exc.start}); save the file as UTF-8") from None


def _check_structure(data) -> None:
    """Refuse YAML whose values nest too deeply, expand (through aliases) to too many
    values, or contain themselves -- before anything walks or prints them."""
    sizes: dict[int, int] = {}

    def size(node, depth: int, path: str) -> int:
        if not isinstance(node, (Mapping, list, set)):
            return 1
        if depth > MAX_NESTING:
            raise ConfigError(f"{path or 'the file'} nests more than {MAX_NESTING} levels deep; "
                              "a sweep file needs at most 4")
        key = id(node)
        if key in sizes:
            if sizes[key] < 0:
                raise ConfigError(f"{path} contains itself (a YAML alias inside its own anchor)")
            return sizes[key]
        sizes[key] = -1
        items = node.items() if isinstance(node, Mapping) else enumerate(node)
        total = 1
        for k, v in items:
            total += size(v, depth + 1, f"{path}.{k}" if path else str(k))
            if total > MAX_VALUES:
                raise ConfigError(f"{path or 'the file'} holds more than {MAX_VALUES} values (YAML aliases "
                                  "expanded); a sweep file is far smaller")
        sizes[key] = total
        return total

    size(data, 0, "")


def _check_range(name: str, value, key: str):
    """``value`` if it lies in ``PARAM_RANGES[name]`` (unknown names pass)."""
    if name not in PARAM_RANGES:
        return value
    lo, hi = PARAM_RANGES[name]
    upper = "<" if name == "density" else "<="
    if not (lo <= value and (value < hi if upper == "<" else value <= hi)):
        raise ConfigError(f"{key} = {_show(value)} is out of range; allowed {lo:g} <= {name} {upper} {hi:g}")
    return value


def _axis_length(name: str, spec) -> int:
    """Values a grid entry will have, without expanding it (0 if it is malformed:
    :func:`_grid_values` then says why)."""
    if isinstance(spec, Mapping):
        num = spec.get("num")
        if isinstance(num, float) and num.is_integer() and math.isfinite(num):
            num = int(num)
        return num if _is_int(num) and num > 0 else 0
    if isinstance(spec, (list, tuple)):
        return len(spec)
    return 1


def _check_run_count(grid_in: Mapping, replicates: int) -> None:
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


def _check_run_length(run: RunSettings, grid: Mapping, model: Mapping) -> None:
    """Frames and cell-steps of one run within MAX_FRAMES and MAX_CELL_STEPS."""
    if run.n_frames > MAX_FRAMES:
        raise ConfigError(f"run.sample_every = {run.sample_every} gives {run.n_frames} frames of run.steps = "
                          f"{run.steps}; allowed at most {MAX_FRAMES} frames per run (sample less often)")
    n_max = max(grid["N"]) if "N" in grid else model["N"]
    if n_max * run.steps > MAX_CELL_STEPS:
        where = "grid.N" if "N" in grid else "model.N"
        raise ConfigError(f"run.steps = {run.steps} with {where} = {n_max} is {n_max * run.steps:.3g} cell-steps "
                          f"per run; allowed N x steps <= {MAX_CELL_STEPS:.0e} (about 3 CPU-years)")


def _check_output_path(output: str) -> None:
    """Output paths that no file system can hold (NUL bytes, over-long names)."""
    if "\0" in output:
        raise ConfigError(f"output = {_show(output)} contains a NUL character; no file system allows it")
    raw = os.fsencode(output)
    if len(raw) > MAX_PATH_BYTES:
        raise ConfigError(f"output = {_show(output)} is {len(raw)} bytes long; allowed at most {MAX_PATH_BYTES}")
    for part in raw.split(b"/"):
        if len(part) > MAX_NAME_BYTES:
            raise ConfigError(f"output = {_show(output)} has a {len(part)}-byte component; allowed at most "
                              f"{MAX_NAME_BYTES} bytes per directory name")


def _grid_or_model(cfg: "SweepConfig", names) -> itertools.product:
    """Every combination of the named parameters over the grid (at most MAX_RUNS)."""
    return itertools.product(*(cfg.grid[n] if n in cfg.grid else (cfg.model[n],) for n in names))


def check_step_sizes(cfg: "SweepConfig") -> None:
    """Refuse grid points whose step moves a cell too far or turns it too much.

    - ``v0 dt <= min(MAX_STEP_PER_SPACING * 2 pi R0 / K, MAX_STEP_PER_R0 * R0)`` (the
      contour term only for ``modes >= 2``): contacts are sampled on the contour points,
      and a cell that jumps a large part of their spacing per step overshoots its
      neighbours' contours;
    - ``D_r dt <= MAX_DR_DT``: the polarity decorrelates within a few steps beyond it,
      and the discrete walk's D0 deviates by (D_r dt)^2 / 12 from v0^2 / (2 D_r).
    """
    def where(name):
        return f"grid.{name}" if name in cfg.grid else f"model.{name}"

    for v0, Dr, dt, R0, K, modes in _grid_or_model(cfg, ("v0", "Dr", "dt", "R0", "contour_points", "modes")):
        limit = MAX_STEP_PER_R0 * R0
        what = f"{MAX_STEP_PER_R0:g} R0"
        if modes >= 2 and MAX_STEP_PER_SPACING * 2 * math.pi * R0 / K < limit:
            limit = MAX_STEP_PER_SPACING * 2 * math.pi * R0 / K
            what = f"half the contour spacing 2 pi R0/K with contour_points = {K}"
        if v0 * dt > limit:
            raise ConfigError(
                f"{where('v0')} = {v0:g} with dt = {dt:g} (R0 = {R0:g}) moves a cell v0*dt = {v0 * dt:.3g} per "
                f"step; allowed v0*dt <= {limit:.4g} ({what}): lower dt or v0")
        if Dr * dt > MAX_DR_DT:
            raise ConfigError(
                f"{where('Dr')} = {Dr:g} with dt = {dt:g} gives Dr*dt = {Dr * dt:.3g}; allowed Dr*dt <= "
                f"{MAX_DR_DT:g} (beyond it the discrete walk no longer has D0 = v0^2/(2 Dr)): lower dt or Dr")


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


# ---------------------------------------------------------------------------- run ids


def _canon_value(name: str, value) -> Any:
    if name in INT_PARAMS:
        return int(value)
    if name in STR_PARAMS:
        return str(value)
    return repr(float(value))


def run_id_of(params: Mapping[str, Any], replicate: int) -> str:
    """Stable 12-hex-digit id of a run from its model parameters and replicate.

    ``seed`` (if present in ``params``) is ignored: the seed derives from the id, and so
    is ``integrator`` when it is the default (ids from before the key existed hold).
    """
    canon = {k: _canon_value(k, v) for k, v in params.items()
             if k != "seed" and not (k == "integrator" and v == DEFAULT_INTEGRATOR)}
    blob = json.dumps({"params": canon, "replicate": int(replicate)}, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(blob.encode()).hexdigest()[:12]


def seed_of(base_seed: int, run_id: str) -> int:
    """Deterministic 63-bit seed of a run: ``SeedSequence([base_seed, int(run_id, 16)])``."""
    ss = np.random.SeedSequence([int(base_seed), int(run_id, 16) % 2**63])
    return int(ss.generate_state(1, dtype=np.uint64)[0] >> np.uint64(1))


def _expand(cfg: SweepConfig) -> list[RunSpec]:
    from fcsweep.io.refinement import RefinementError, read_points

    names = list(cfg.grid)
    try:
        extra = read_points(cfg.output)
    except RefinementError as exc:
        raise ConfigError(str(exc)) from None
    points = []
    for k, point in enumerate(extra):
        if sorted(point) != sorted(names):
            raise ConfigError(
                f"{cfg.output}/refinement.json point {k} has parameters {sorted(point)} but the grid sweeps "
                f"{sorted(names)}; refined points belong to the grid they were made for (move the file away "
                "to use this config with this output directory)")
        points.append(tuple(_check_param(n, point[n], "refinement") for n in names))
    specs = []
    index = 0
    seen = set()
    for combo in itertools.chain(itertools.product(*(cfg.grid[n] for n in names)), points):
        key = tuple(_canon_value(n, v) for n, v in zip(names, combo))
        if key in seen:
            continue
        seen.add(key)
        for rep in range(cfg.replicates):
            params = dict(cfg.model)
            params.update(zip(names, combo))
            params = {k: params[k] for k in MODEL_DEFAULTS}  # fixed key order
            rid = run_id_of(params, rep)
            params["seed"] = seed_of(cfg.seed, rid)
            specs.append(RunSpec(index, rid, params, rep, tuple(names)))
            index += 1
    return specs
