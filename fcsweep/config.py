"""Sweep configuration: YAML -> validated, frozen run specifications.

A sweep file has six top-level sections (see ``results_schema.md`` and the README)::

    output: runs/phase            # or {dir: runs/phase, fields: [...], compression: gzip}
    seed: 12345
    replicates: 1
    grid: {eta: [0.01, 0.1], v0: {start: 0.01, stop: 0.06, num: 6}, N: [1024]}
    model: {density: 0.95, Dr: 0.01, dt: 0.005, modes: 6, contour_points: 40}
    run: {steps: 1000000, sample_every: 1000, checkpoint_every: 100000, transient: 0.2,
          until: {check_every: 100000, min_steps: 200000, confidence: 0.95}}   # until optional

Everything is validated before anything runs; the problems of a file raise one
:class:`ConfigError` listing them all, each naming the key, the offending value and what
is allowed.  Numbers are read as YAML 1.2 and Python read them (``5e-3``, ``2.0e3``; PyYAML
alone follows YAML 1.1, where these are strings); integer settings take floats with an
integral value.  :func:`json_schema` describes the format for editors.

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
:func:`fcsweep.sweep.lifecycle.fingerprint_of`).  Grid points added by ``fcsweep refine``
live with the results in ``<output>/refinement.json`` (:mod:`fcsweep.io.refinement`; the
user's YAML is never edited) and follow the product grid's runs, so existing run indices
never change.  They are read once, when the config is bound to its output directory
(:func:`load_config`, :meth:`SweepConfig.with_output`, :meth:`SweepConfig.with_refinement`;
:func:`parse_config` returns an unbound config), so that :meth:`SweepConfig.runs` is a
pure function of the config and all commands of one process see the same runs.

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
    "MAX_LISTED",
    "check_step_sizes",
    "check_memory",
    "run_memory_bytes",
    "machine_memory_bytes",
    "json_schema",
]


def _one_line(message) -> str:
    return re.sub(r"\s*[\r\n]+\s*", " ", str(message)).strip()


class ConfigError(ValueError):
    """An invalid sweep configuration; the message names key, value and what is allowed.

    Every problem is one line (line breaks of quoted parser messages are folded).  A file
    with one problem gives a one-line message, exactly ``"<source>: <problem>"`` when
    ``source`` is given; a file with several gives a first line
    ``"<source>: <n> problems:"`` and then one indented line per problem (at most
    :data:`MAX_LISTED`, then how many more).

    Parameters
    ----------
    message : str
        The problem (ignored when ``problems`` is given).
    problems : sequence of str, optional
        Several problems of one file, reported together.
    source : str, optional
        The file they concern, prefixed to the message.

    Attributes
    ----------
    problems : tuple of str
        The problems, one line each, without ``source``.
    source : str
    """

    def __init__(self, message: str = "", *, problems=None, source: str = ""):
        self.problems = tuple(_one_line(p) for p in (problems if problems else [message]))
        self.source = str(source)
        prefix = f"{self.source}: " if self.source else ""
        if len(self.problems) == 1:
            text = prefix + self.problems[0]
        else:
            shown = self.problems[:MAX_LISTED]
            more = len(self.problems) - len(shown)
            text = f"{prefix}{len(self.problems)} problems:" + "".join(f"\n  {p}" for p in shown)
            if more:
                text += f"\n  ... and {more} more"
        super().__init__(text)

    def with_source(self, source: str) -> "ConfigError":
        """The same problems, prefixed with ``source`` (replacing any source it had)."""
        return ConfigError(problems=self.problems, source=source)


#: Most problems one :class:`ConfigError` lists (the first line still counts all).
MAX_LISTED = 30

#: Sentinel of a value whose check failed (its problem is recorded in a :class:`_Problems`).
_FAILED = object()


class _Problems:
    """The problems of one file, collected so that all are reported at once."""

    def __init__(self):
        self.messages: list[str] = []

    @property
    def count(self) -> int:
        return len(self.messages)

    def add(self, exc: ConfigError) -> None:
        for p in exc.problems:
            if p not in self.messages:
                self.messages.append(p)

    def attempt(self, fn, *args, **kwargs):
        """``fn(*args, **kwargs)``, or :data:`_FAILED` with its ConfigError recorded."""
        try:
            return fn(*args, **kwargs)
        except ConfigError as exc:
            self.add(exc)
            return _FAILED

    def keys(self, d: Mapping, allowed, where: str) -> set:
        """Record every key of ``d`` not in ``allowed``; return the keys suggested instead
        (a section misspelled as a suggested key is not reported missing as well)."""
        suggested = set()
        for k in d:
            if k not in allowed:
                self.add(_unknown(k, allowed, where))
                hint = _suggest(k, allowed)
                if hint is not None:
                    suggested.add(hint)
        return suggested

    def raise_if_any(self, source: str = "") -> None:
        if self.messages:
            raise ConfigError(problems=self.messages, source=source)


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
    refined : tuple of dict
        Grid points ``fcsweep refine`` recorded in ``<output>/refinement.json``, read
        once when the config is bound to its output directory (:func:`load_config`,
        :meth:`with_output`, :meth:`with_refinement`), so that :meth:`runs` reads no file
        and every call in a process gives the same runs.
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
    refined: tuple[Mapping[str, Any], ...] = ()

    @property
    def swept(self) -> list[str]:
        """Swept parameter names in grid order."""
        return list(self.grid)

    def runs(self) -> list[RunSpec]:
        """All runs: grid points in grid order (last key fastest), replicates innermost,
        then the points ``fcsweep refine`` added (:attr:`refined`) in the order they
        were added.  A pure function of the config: it reads no file.

        Raises
        ------
        ConfigError
            If the refinement points do not fit this grid.
        """
        return _expand(self)

    def run_dir(self, run_id: str) -> Path:
        """Directory of one run: ``output / "runs" / run_id``."""
        from fcsweep.io.sweepdir import run_path

        return run_path(self.output, run_id)

    def with_output(self, output: str | os.PathLike) -> "SweepConfig":
        """Copy of this config bound to another directory, with that directory's refinement
        points (ids are unchanged)."""
        return dataclasses.replace(self, output=Path(output)).with_refinement()

    def with_refinement(self) -> "SweepConfig":
        """Copy of this config with the points now in ``<output>/refinement.json``.

        Raises
        ------
        ConfigError
            If the file cannot be read or is not a refinement file.
        """
        from fcsweep.io.refinement import RefinementError
        from fcsweep.io.sweepdir import refinement_points

        try:
            points = refinement_points(self.output)
        except RefinementError as exc:
            raise ConfigError(str(exc)) from None
        return dataclasses.replace(self, refined=points)

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


# Numbers as YAML 1.2 (core schema) and Python read them.  PyYAML follows YAML 1.1, where
# a float needs a dot and a signed exponent: there ``5e-3``, ``1E-2``, ``1e3`` and ``2.0e3``
# are strings.  Added here: a decimal with an exponent, sign optional -- exactly what
# Python's float() accepts (``_`` only between digits) -- and ``0o17`` octal (YAML 1.2,
# Python).  ``017`` is 17 (YAML 1.2) and not 15 (YAML 1.1 octal).  Everything YAML 1.1
# already reads as a number (``.inf``, ``1_000``, ``0x1f``, ``0b101``) reads as before.
_DIGITS = r"[0-9](?:_?[0-9])*"
_EXPONENT_FLOAT = re.compile(
    rf"^[-+]?(?:{_DIGITS}(?:\.(?:{_DIGITS})?)?|\.{_DIGITS})[eE][-+]?{_DIGITS}$")
_OCTAL_12 = re.compile(r"^[-+]?0o[0-7](?:_?[0-7])*$")
_UniqueKeyLoader.add_implicit_resolver("tag:yaml.org,2002:float", _EXPONENT_FLOAT, list("-+.0123456789"))
_UniqueKeyLoader.add_implicit_resolver("tag:yaml.org,2002:int", _OCTAL_12, list("-+0"))


def _construct_int_12(loader, node):
    text = str(node.value)
    digits = text.lstrip("+-").replace("_", "")
    if _OCTAL_12.match(text) or (len(digits) > 1 and digits[0] == "0" and digits.isdigit()):
        sign = -1 if text.startswith("-") else 1
        base = 8 if _OCTAL_12.match(text) else 10
        body = digits[2:] if base == 8 else digits
        if len(body) > 4300:
            return _construct_int(loader, node)  # the digit-limit message
        return sign * int(body, base)
    return _construct_int(loader, node)


_UniqueKeyLoader.add_constructor("tag:yaml.org,2002:int", _construct_int_12)


def builtin_demo_path() -> Path:
    """Path of the built-in demo sweep shipped with the package (``fcsweep/data/smoke.yaml``)."""
    from importlib.resources import files

    return Path(str(files("fcsweep") / "data" / "smoke.yaml"))


def load_config(path: str | os.PathLike) -> SweepConfig:
    """Read and validate a sweep YAML file.

    The config is bound to its output directory: it holds the points recorded in
    ``<output>/refinement.json`` (:meth:`SweepConfig.with_refinement`).

    Raises
    ------
    ConfigError
        If the file is missing, not YAML, or any value is invalid, or the output's
        refinement file cannot be read.
    """
    path = Path(path)
    return parse_config(_read_text(path), source=str(path)).with_refinement()


def parse_config(text: str, source: str = "<string>") -> SweepConfig:
    """Validate a sweep given as YAML text. See :func:`load_config` (unlike it, no
    refinement points are read: :meth:`SweepConfig.with_refinement` adds them)."""
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
        raise exc.with_source(source) from None
    except (ArithmeticError, TypeError, ValueError, RecursionError) as exc:  # a check missed: still no traceback
        raise ConfigError(f"{source}: {UNCHECKED} ({type(exc).__name__}: {exc})") from None


# -------------------------------------------------------------------------- validation


def _edit_distance(a: str, b: str) -> int:
    """Optimal-string-alignment distance (insertions, deletions, substitutions, swaps)."""
    prev2, prev = None, list(range(len(b) + 1))
    for i, ca in enumerate(a, 1):
        cur = [i] + [0] * len(b)
        for j, cb in enumerate(b, 1):
            cur[j] = min(prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + (ca != cb))
            if prev2 is not None and i > 1 and j > 1 and ca == b[j - 2] and a[i - 2] == cb:
                cur[j] = min(cur[j], prev2[j - 2] + 1)
        prev2, prev = prev, cur
    return prev[-1]


def _suggest(key, allowed) -> str | None:
    """The allowed key ``key`` most likely misspells, or ``None``: difflib's closest match,
    else one that differs only in case, else (keys of 2+ characters, where difflib's
    ratio is too coarse: ``vo`` for ``v0``) one a single edit away."""
    allowed = [str(a) for a in allowed]
    key = str(key)
    close = difflib.get_close_matches(key, allowed, n=1, cutoff=0.6)
    if not close:
        close = [a for a in allowed if a.lower() == key.lower()]
    if not close and 2 <= len(key) <= 40:
        close = [a for a in allowed if _edit_distance(key.lower(), a.lower()) == 1]
    return close[0] if close else None


def _unknown(key: str, allowed, where: str) -> ConfigError:
    close = _suggest(key, allowed)
    hint = f"; did you mean {close!r}?" if close is not None else ""
    return ConfigError(
        f"unknown key {where}{_show(key)}{hint} (allowed: {', '.join(map(str, allowed))})"
    )


def _is_int(x) -> bool:
    return isinstance(x, (int, np.integer)) and not isinstance(x, bool)


def _is_real(x) -> bool:
    return isinstance(x, (int, float, np.integer, np.floating)) and not isinstance(x, bool)


def _allowed(name: str) -> str:
    """What a model parameter may be, as in the range messages (``allowed 1e-06 <= dt <= 1``)."""
    if name in STR_PARAMS:
        return f"choose one of {list(STR_PARAMS[name])}"
    if name == "N":
        return f"allowed N = n*n with n even, 4 <= N <= {PARAM_RANGES['N'][1]}"
    if name == "modes":
        return "allowed 0 (rigid discs) or 2..32"
    lo, hi = PARAM_RANGES[name]
    return f"allowed {lo:g} <= {name} {'<' if name == 'density' else '<='} {hi:g}"


def _int(value, key: str, *, minimum: int | None = None, maximum: int | None = None,
         allowed: str | None = None) -> int:
    """``value`` as an int: an integer, or a float with an integral value (``2.0e3``).

    ``allowed`` describes the range in the type error (default: from the bounds)."""
    name = key.rsplit('.', 1)[-1]
    if allowed is None:
        if minimum is not None and maximum is not None:
            allowed = f"allowed {minimum} <= {name} <= {maximum}"
        elif minimum is not None:
            allowed = f"allowed {name} >= {minimum}"
    kind = f"must be an integer; {allowed}" if allowed else "must be an integer"
    if isinstance(value, float) and value.is_integer() and abs(value) < 2**53:
        value = int(value)
    if maximum is not None and _is_real(value) and value > maximum:  # also 1e30, before int() of it
        low = f"{minimum} <= " if minimum is not None else ""
        raise ConfigError(f"{key} = {_show(value)} is out of range; allowed {low}{name} <= {maximum}")
    if isinstance(value, float) and value.is_integer():  # beyond 2**53 a float is not exact
        raise ConfigError(f"{key} = {_show(value)} {kind} (write it in digits: a float above 2**53 "
                          "is not an exact integer)")
    if not _is_int(value):
        raise ConfigError(f"{key} = {_show(value)} {kind}")
    value = int(value)
    if minimum is not None and value < minimum:
        raise ConfigError(f"{key} = {value} must be an integer >= {minimum}")
    return value


def _real(value, key: str, allowed: str | None = None) -> float:
    """``value`` as a finite float; ``allowed`` describes the range in the type error."""
    tail = f"; {allowed}" if allowed else ""
    if not _is_real(value):
        raise ConfigError(f"{key} = {_show(value)} must be a number{tail}")
    try:
        value = float(value)
    except OverflowError:  # an int beyond float range
        raise ConfigError(f"{key} = {_show(value)} must be a finite number{tail}") from None
    if not math.isfinite(value):
        raise ConfigError(f"{key} = {value!r} must be a finite number{tail}")
    return value


def _check_param(name: str, value, where: str) -> Any:
    """Validate and canonicalise one model parameter value."""
    key = f"{where}.{name}"
    if name in STR_PARAMS:
        if not isinstance(value, str) or value not in STR_PARAMS[name]:
            raise ConfigError(f"{key} = {_show(value)} is not allowed; choose one of {list(STR_PARAMS[name])}")
        return value
    if name == "N":
        n = _int(value, key, minimum=4, maximum=PARAM_RANGES["N"][1], allowed=_allowed("N"))
        from fcsweep.model.lattice import lattice_side

        try:
            lattice_side(n)
        except ValueError as exc:
            raise ConfigError(f"{key} = {value!r}: {exc}") from None
        return n
    if name == "modes":
        m = _int(value, key, minimum=0, allowed=_allowed("modes"))
        if m == 1 or m > 32:
            raise ConfigError(f"{key} = {m} is not allowed; modes is 0 (rigid discs) or 2..32")
        return m
    if name == "contour_points":
        return _int(value, key, minimum=8, maximum=PARAM_RANGES["contour_points"][1])
    x = _real(value, key, _allowed(name))
    if name in ("eta", "v0", "Dr") and x < 0:
        raise ConfigError(f"{key} = {value!r} is out of range; {name} must be >= 0")
    if name in ("mu_theta", "mu_shape") and x < 0:
        raise ConfigError(f"{key} = {value!r} is out of range; {name} must be >= 0")
    if name == "density" and not 0.0 < x < 1.0:
        raise ConfigError(f"{key} = {value!r} is out of range; density must lie in (0, 1)")
    if name in ("dt", "R0") and x <= 0:
        raise ConfigError(f"{key} = {value!r} is out of range; {name} must be > 0")
    return _check_range(name, x, key)


def _grid_values(name: str, spec, problems: _Problems | None = None):
    """The values of one grid entry, each checked as a model parameter; its problems go
    to ``problems`` (then :data:`_FAILED` is returned) or are raised."""
    local = _Problems() if problems is None else problems
    first = local.count
    values = _grid_raw_values(name, spec, local)
    if values is not _FAILED:
        is_range = isinstance(spec, Mapping)
        out = []
        for v in values:
            x = local.attempt(_check_param, name, v, "grid")
            if x is _FAILED and is_range:  # one message for a range, not one per value
                break
            out.append(x)
        if local.count == first:
            canon = Counter(_canon_value(name, v) for v in out)
            if len(canon) != len(out):
                dup = next(c for c, n in canon.items() if n > 1)
                local.add(ConfigError(f"grid.{name} = {_show(list(values))} repeats the value {dup}; "
                                      "each value once"))
            values = tuple(out)
    if problems is None:
        local.raise_if_any()
    return values if local.count == first else _FAILED


def _grid_raw_values(name: str, spec, problems: _Problems):
    """The unchecked values of a grid entry (a range expanded), or :data:`_FAILED`."""
    key = f"grid.{name}"
    if isinstance(spec, Mapping):
        first = problems.count
        suggested = problems.keys(spec, RANGE_KEYS, f"in {key}: ")
        missing = [k for k in ("start", "stop", "num") if k not in spec]
        if [k for k in missing if k not in suggested]:
            problems.add(ConfigError(
                f"{key} = {_show(dict(spec))} is missing {missing}; a range is {{start, stop, num[, log]}}"))
        if missing:
            return _FAILED
        allowed = _allowed(name) if name in PARAM_RANGES else None
        start = problems.attempt(_real, spec["start"], f"{key}.start", allowed)
        stop = problems.attempt(_real, spec["stop"], f"{key}.stop", allowed)
        num = problems.attempt(_int, spec["num"], f"{key}.num", minimum=1, maximum=MAX_RUNS)
        log = spec.get("log", False)
        if not isinstance(log, bool):
            problems.add(ConfigError(f"{key}.log = {_show(log)} must be true or false"))
        if name in STR_PARAMS:
            problems.add(ConfigError(f"{key} = {_show(dict(spec))}: {name} takes a list of names, not a range"))
        if problems.count > first:
            return _FAILED
        if log:
            if start <= 0 or stop <= 0:
                problems.add(ConfigError(
                    f"{key} = {_show(dict(spec))}: a log range needs start > 0 and stop > 0"))
                return _FAILED
            values = np.geomspace(start, stop, num)
        else:
            values = np.linspace(start, stop, num)
        # 12 significant digits: linspace(0.01, 0.06, 6) gives 0.03, not 0.030000000000000002
        values = [float(f"{v:.12g}") for v in values]
        if name in INT_PARAMS:
            if any(not float(v).is_integer() for v in values):
                problems.add(ConfigError(
                    f"{key} = {_show(dict(spec))} gives non-integer values {values}; "
                    f"{name} must be integers (use a list)"))
                return _FAILED
            values = [int(v) for v in values]
        return values
    if isinstance(spec, (list, tuple)):
        if len(spec) == 0:
            problems.add(ConfigError(f"{key} = [] is empty; give at least one value"))
            return _FAILED
        return list(spec)
    if isinstance(spec, (str, int, float)) and not isinstance(spec, bool):
        return [spec]
    problems.add(ConfigError(f"{key} = {_show(spec)} must be a list of values or {{start, stop, num}}"))
    return _FAILED


def check_runnable(cfg: "SweepConfig") -> None:
    """Checks that concern running a sweep, not reading one: raise :class:`ConfigError`
    (all problems at once, the first grid point of each kind) if some grid point cannot
    be integrated faithfully.

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
    problems = _Problems()

    def where(name):
        return f"grid.{name}" if name in grid else f"model.{name}"

    names = ("dt", "eta", "modes", "mu_shape", "R0", "contour_points")
    found = {"contour_points": False, "dt": False}
    for dt, eta, modes, mu_shape, R0, K in _grid_or_model(cfg, names):
        for name, problem in (("contour_points", not found["contour_points"] and contour_points_problem(K, modes)),
                              ("dt", not found["dt"] and dt_problem(dt, eta, modes, mu_shape, R0))):
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


def _validate(data, source: str) -> SweepConfig:
    """The validated config, or one ConfigError listing every problem of ``data``."""
    if data is None:
        raise ConfigError("the file is empty; a sweep needs at least 'grid' and 'run'")
    if not isinstance(data, Mapping):
        raise ConfigError(f"top level must be a mapping of sections, got {type(data).__name__}")
    problems = _Problems()
    suggested = problems.keys(data, TOP_KEYS, "")
    for req in ("output", "grid", "run"):
        if req not in data and req not in suggested:
            problems.add(ConfigError(f"missing required section {req!r}"))

    out = _output_section(data["output"], problems) if "output" in data else _FAILED
    seed = problems.attempt(_seed, data.get("seed", 0))
    replicates = problems.attempt(_int, data.get("replicates", 1), "replicates", minimum=1, maximum=MAX_RUNS)
    description = data.get("description", "")
    if not isinstance(description, str):
        problems.add(ConfigError(f"description = {_show(description)} must be a string"))

    # grid
    grid, swept, log_axes = _FAILED, set(), ()
    grid_in = data.get("grid")
    grid_named = isinstance(grid_in, Mapping) and len(grid_in) > 0  # so missing parameters are meaningful
    if "grid" in data:
        if not isinstance(grid_in, Mapping):
            problems.add(ConfigError(f"grid = {_show(grid_in)} must be a mapping of parameter -> values"))
        elif len(grid_in) == 0:
            problems.add(ConfigError("grid = {} is empty; sweep at least one model parameter"))
        else:
            first = problems.count
            suggested = problems.keys(grid_in, list(MODEL_DEFAULTS), "in grid: ")
            known = {k: v for k, v in grid_in.items() if k in MODEL_DEFAULTS}
            swept = set(known) | suggested
            counted = problems.attempt(_check_run_count, known, 1 if replicates is _FAILED else replicates)
            if counted is not _FAILED:  # expand nothing that may be huge
                grid = {str(k): _grid_values(str(k), v, problems) for k, v in known.items()}
                log_axes = tuple(str(k) for k, v in known.items() if isinstance(v, Mapping) and v.get("log") is True)
            if problems.count > first:
                grid = _FAILED

    model = _model_section(data.get("model") or {}, swept, grid_named, problems)
    run = _run_section(data["run"], problems) if "run" in data else _FAILED
    if not any(x is _FAILED for x in (run, grid, model)):
        problems.attempt(_check_run_length, run, grid, model)
    problems.raise_if_any()
    output, store = out
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


def _seed(value) -> int:
    seed = _int(value, "seed", minimum=0, allowed="allowed 0 <= seed < 2**63")
    if seed >= 2**63:
        raise ConfigError(f"seed = {seed} is out of range; allowed 0 <= seed < 2**63")
    return seed


def _output_section(out, problems: _Problems):
    """``(output directory, StoreSettings)`` of the ``output`` section, or :data:`_FAILED`."""
    first = problems.count
    store = StoreSettings()
    if isinstance(out, Mapping):
        problems.keys(out, OUTPUT_KEYS, "in output: ")
        fields = out.get("fields", list(DEFAULT_FIELDS))
        if not isinstance(fields, (list, tuple)) or not all(isinstance(f, str) for f in fields):
            problems.add(ConfigError(f"output.fields = {_show(fields)} must be a list of names from {list(FIELDS)}"))
        else:
            for f in fields:
                if f not in FIELDS:
                    problems.add(_unknown(f, FIELDS, "in output.fields: "))
            fields = tuple(f for f in FIELDS if f in set(fields) | {"position", "image"})
        comp = out.get("compression", "gzip")
        if comp not in COMPRESSIONS:
            problems.add(ConfigError(
                f"output.compression = {_show(comp)} is not allowed; choose one of {list(COMPRESSIONS)}"))
        level = problems.attempt(_int, out.get("compression_level", 4), "output.compression_level", minimum=0,
                                 allowed="allowed 0..9")
        if level is not _FAILED and level > 9:
            problems.add(ConfigError(f"output.compression_level = {level} is out of range; allowed 0..9"))
        if "dir" not in out:
            problems.add(ConfigError("output.dir is missing; give the sweep directory"))
            return _FAILED
        if problems.count == first:
            store = StoreSettings(fields=fields, compression=comp, compression_level=level)
        out = out["dir"]
    if not isinstance(out, str) or not out.strip():
        problems.add(ConfigError(f"output = {_show(out)} must be a directory path (string)"))
    else:
        problems.attempt(_check_output_path, out)
    if problems.count > first:
        return _FAILED
    return Path(os.path.expanduser(out)), store


def _model_section(model_in, swept: set, grid_named: bool, problems: _Problems):
    """The fixed model parameters, defaults filled in, or :data:`_FAILED`.

    ``swept``: the grid's parameters (and those a misspelled grid key suggests);
    ``grid_named``: whether the grid is a non-empty mapping, so that a parameter in
    neither place is missing (and not a consequence of a broken grid).
    """
    if not isinstance(model_in, Mapping):
        problems.add(ConfigError(f"model = {_show(model_in)} must be a mapping of parameter -> value"))
        return _FAILED
    first = problems.count
    suggested = problems.keys(model_in, list(MODEL_DEFAULTS), "in model: ")
    model: dict[str, Any] = {}
    for name, default in MODEL_DEFAULTS.items():
        if name in swept:
            if name in model_in:
                problems.add(ConfigError(
                    f"model.{name} = {_show(model_in[name])} is also swept in grid.{name}; "
                    "give it in one place only"))
            continue
        if name in model_in:
            model[name] = problems.attempt(_check_param, name, model_in[name], "model")
        elif default is None:
            if grid_named and name not in suggested:
                problems.add(ConfigError(f"model parameter {name!r} is missing; give it in 'model' or 'grid'"))
            model[name] = _FAILED
        else:
            model[name] = default
    return model if problems.count == first and _FAILED not in model.values() else _FAILED


def _run_section(run_in, problems: _Problems):
    """The :class:`RunSettings` of the ``run`` section, or :data:`_FAILED`."""
    if not isinstance(run_in, Mapping):
        problems.add(ConfigError(f"run = {_show(run_in)} must be a mapping"))
        return _FAILED
    first = problems.count
    suggested = problems.keys(run_in, RUN_KEYS, "in run: ")
    for req in ("steps", "sample_every"):
        if req not in run_in and req not in suggested:
            problems.add(ConfigError(f"run.{req} is missing"))
    steps = sample_every = checkpoint_every = _FAILED
    if "steps" in run_in:
        steps = problems.attempt(_int, run_in["steps"], "run.steps", minimum=1, maximum=MAX_STEPS)
    if "sample_every" in run_in:
        sample_every = problems.attempt(_int, run_in["sample_every"], "run.sample_every", minimum=1,
                                        maximum=MAX_STEPS)
    if steps is not _FAILED and sample_every is not _FAILED and steps % sample_every:
        problems.add(ConfigError(
            f"run.steps = {steps} is not a multiple of run.sample_every = {sample_every}; "
            "steps must be a whole number of frames"))
    if "checkpoint_every" in run_in or steps is not _FAILED:
        checkpoint_every = problems.attempt(_int, run_in.get("checkpoint_every", steps), "run.checkpoint_every",
                                            minimum=1, maximum=MAX_STEPS)
    if checkpoint_every is not _FAILED and sample_every is not _FAILED and checkpoint_every % sample_every:
        problems.add(ConfigError(
            f"run.checkpoint_every = {checkpoint_every} is not a multiple of run.sample_every = "
            f"{sample_every}; checkpoints are taken on frame boundaries"))
    transient = problems.attempt(_real, run_in.get("transient", 0.2), "run.transient",
                                 "allowed 0 <= transient < 1")
    if transient is not _FAILED and not 0.0 <= transient < 1.0:
        problems.add(ConfigError(f"run.transient = {transient!r} is out of range; allowed 0 <= transient < 1"))
    until = None
    if run_in.get("until") is not None:
        if problems.count > first:  # until's bounds refer to steps and checkpoint_every
            return _FAILED
        until = _until(run_in["until"], steps, sample_every, checkpoint_every, problems)
    if problems.count > first:
        return _FAILED
    return RunSettings(steps, sample_every, checkpoint_every, transient, until)


def _until(until_in, steps: int, sample_every: int, checkpoint_every: int,
           problems: _Problems | None = None) -> UntilSettings:
    """Validate ``run.until``; every message names the key and its allowed range.

    Problems go to ``problems`` (then :data:`_FAILED` is returned) or are raised."""
    local = _Problems() if problems is None else problems
    first = local.count
    result = _until_settings(until_in, steps, checkpoint_every, local)
    if problems is None:
        local.raise_if_any()
    return result if local.count == first else _FAILED


def _until_settings(until_in, steps: int, checkpoint_every: int, problems: _Problems):
    if not isinstance(until_in, Mapping):
        problems.add(ConfigError(f"run.until = {until_in!r} must be a mapping with keys {', '.join(UNTIL_KEYS)}"))
        return _FAILED
    suggested = problems.keys(until_in, UNTIL_KEYS, "in run.until: ")
    check_every = _FAILED
    if "check_every" not in until_in:
        if "check_every" not in suggested:
            problems.add(ConfigError(
                f"run.until.check_every is missing; give the steps between checks, a multiple of "
                f"run.checkpoint_every = {checkpoint_every} and at most run.steps = {steps}"))
    else:
        check_every = problems.attempt(_int, until_in["check_every"], "run.until.check_every", minimum=1,
                                       allowed=f"allowed a multiple of run.checkpoint_every = {checkpoint_every}, "
                                               f"at most run.steps = {steps}")
        if check_every is not _FAILED and (check_every % checkpoint_every or check_every > steps):
            problems.add(ConfigError(
                f"run.until.check_every = {check_every} is not allowed; it must be a multiple of "
                f"run.checkpoint_every = {checkpoint_every} (checks happen at checkpoints) and at most "
                f"run.steps = {steps}"))
            check_every = _FAILED
    min_steps = _FAILED
    if "min_steps" in until_in or check_every is not _FAILED:
        min_steps = problems.attempt(_int, until_in.get("min_steps", check_every), "run.until.min_steps", minimum=0,
                                     allowed=f"allowed 0 <= min_steps <= run.steps = {steps}")
    if min_steps is not _FAILED and min_steps > steps:
        problems.add(ConfigError(f"run.until.min_steps = {min_steps} is out of range; allowed 0 <= min_steps <= "
                                 f"run.steps = {steps}"))
    confidence = problems.attempt(_real, until_in.get("confidence", UNTIL_CONFIDENCE), "run.until.confidence",
                                  "allowed 0.5 <= confidence < 1")
    if confidence is not _FAILED and not 0.5 <= confidence < 1.0:
        problems.add(ConfigError(
            f"run.until.confidence = {confidence!r} is out of range; allowed 0.5 <= confidence < 1 "
            "(the probability both labels must reach)"))
    rel_in = until_in.get("rel_error") or {}
    rel = []
    if not isinstance(rel_in, Mapping):
        problems.add(ConfigError(f"run.until.rel_error = {rel_in!r} must be a mapping observable -> target, "
                                 f"observables from {list(UNTIL_OBSERVABLES)}"))
    else:
        problems.keys(rel_in, UNTIL_OBSERVABLES, "in run.until.rel_error: ")
        for name in UNTIL_OBSERVABLES:
            if name in rel_in:
                x = problems.attempt(_real, rel_in[name], f"run.until.rel_error.{name}", "allowed 0 < target <= 1")
                if x is not _FAILED and not 0.0 < x <= 1.0:
                    problems.add(ConfigError(
                        f"run.until.rel_error.{name} = {x!r} is out of range; allowed 0 < target <= 1 "
                        "(1-sigma error / |value|)"))
                rel.append((name, x))
    if _FAILED in (check_every, min_steps, confidence) or any(x is _FAILED for _, x in rel):
        return _FAILED
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

    Both are reported together, each at the first grid point that breaks it.
    """
    def where(name):
        return f"grid.{name}" if name in cfg.grid else f"model.{name}"

    step = turn = None  # the first grid point of each kind: a message per kind, not per point
    for v0, Dr, dt, R0, K, modes in _grid_or_model(cfg, ("v0", "Dr", "dt", "R0", "contour_points", "modes")):
        limit = MAX_STEP_PER_R0 * R0
        what = f"{MAX_STEP_PER_R0:g} R0"
        if modes >= 2 and MAX_STEP_PER_SPACING * 2 * math.pi * R0 / K < limit:
            limit = MAX_STEP_PER_SPACING * 2 * math.pi * R0 / K
            what = f"half the contour spacing 2 pi R0/K with contour_points = {K}"
        if step is None and v0 * dt > limit:
            step = (f"{where('v0')} = {v0:g} with dt = {dt:g} (R0 = {R0:g}) moves a cell v0*dt = {v0 * dt:.3g} per "
                    f"step; allowed v0*dt <= {limit:.4g} ({what}): lower dt or v0")
        if turn is None and Dr * dt > MAX_DR_DT:
            turn = (f"{where('Dr')} = {Dr:g} with dt = {dt:g} gives Dr*dt = {Dr * dt:.3g}; allowed Dr*dt <= "
                    f"{MAX_DR_DT:g} (beyond it the discrete walk no longer has D0 = v0^2/(2 Dr)): lower dt or Dr")
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


# ------------------------------------------------------------------------ JSON Schema

#: One line per model parameter for the JSON Schema (editors show it on hover).
_PARAM_DOC = {
    "N": "number of cells, an n x n hexagonal lattice: n*n with n even (16, 36, 64, ..., 1024)",
    "eta": "membrane tension",
    "v0": "self-propulsion speed (v0*dt within the step bound)",
    "Dr": "rotational diffusion (Dr*dt <= 0.1)",
    "density": "area fraction",
    "dt": "time step (also below the tension limit 1.5/lambda_M)",
    "contour_points": "contour quadrature points K (> 2 modes)",
    "modes": "highest Fourier mode M: 0 (rigid discs) or 2..32",
    "quadrature": "contact quadrature (binary: the paper's)",
    "R0": "radius of the circle of equal area",
    "mu_theta": "mobility of the polarity angle",
    "mu_shape": "mobility of the shape modes",
    "integrator": "time step scheme (euler: the paper's)",
}


def _param_schema(name: str) -> dict[str, Any]:
    """JSON Schema of one model parameter value, from PARAM_RANGES and STR_PARAMS."""
    doc = {"description": f"{_PARAM_DOC.get(name, name)}; {_allowed(name)}"}
    if name in STR_PARAMS:
        return {**doc, "type": "string", "enum": list(STR_PARAMS[name])}
    lo, hi = PARAM_RANGES[name]
    if name in INT_PARAMS:
        schema = {"type": "integer", "minimum": lo, "maximum": hi}
        if name == "modes":
            schema["not"] = {"const": 1}
        return {**doc, **schema}
    upper = "exclusiveMaximum" if name == "density" else "maximum"
    return {**doc, "type": "number", "minimum": lo, upper: hi}


def json_schema() -> dict[str, Any]:
    """JSON Schema (draft-07) of a sweep YAML file, for editors' YAML language servers.

    Generated from the tables the validation uses (:data:`PARAM_RANGES`, the allowed keys
    and names, the resource bounds); ``fcsweep schema`` prints it.  It checks keys, types
    and per-value ranges; what involves several values (N = n*n with n even, steps a
    multiple of sample_every, v0*dt, the run count, ...) only :func:`load_config` and
    :func:`check_runnable` check.

    Returns
    -------
    dict
        The schema, JSON-serialisable.
    """
    def obj(properties: dict, required=(), **extra) -> dict:
        out = {"type": "object", "properties": properties, "additionalProperties": False, **extra}
        if required:
            out["required"] = list(required)
        return out

    def integer(lo: int, hi: int | None = None, description: str = "") -> dict:
        out = {"type": "integer", "minimum": lo}
        if hi is not None:
            out["maximum"] = hi
        return {"description": description, **out} if description else out

    params = {name: _param_schema(name) for name in MODEL_DEFAULTS}
    grid_entry = {}
    for name, value in params.items():
        choices = [value, {"type": "array", "items": value, "minItems": 1, "uniqueItems": True}]
        if name not in STR_PARAMS:
            number = {"type": "number", **{k: v for k, v in value.items() if k.endswith(("imum", "Maximum"))}}
            choices.append(obj({"start": number, "stop": number, "num": integer(1, MAX_RUNS),
                                "log": {"type": "boolean"}}, ("start", "stop", "num"),
                               description="numpy.linspace(start, stop, num), or geomspace with log: true"))
        grid_entry[name] = {"description": value["description"], "anyOf": choices}
    output = obj({
        "dir": {"type": "string", "minLength": 1},
        "fields": {"type": "array", "items": {"enum": list(FIELDS)}, "uniqueItems": True},
        "compression": {"enum": list(COMPRESSIONS)},
        "compression_level": integer(0, 9),
    }, ("dir",))
    until = obj({
        "check_every": integer(1, MAX_STEPS, "steps between checks: a multiple of run.checkpoint_every, "
                                             "<= run.steps"),
        "min_steps": integer(0, MAX_STEPS, "no check before this step (<= run.steps)"),
        "confidence": {"type": "number", "minimum": 0.5, "exclusiveMaximum": 1},
        "rel_error": obj({name: {"type": "number", "exclusiveMinimum": 0, "maximum": 1}
                          for name in UNTIL_OBSERVABLES}),
    }, ("check_every",))
    run = obj({
        "steps": integer(1, MAX_STEPS, "integration steps, a multiple of sample_every"),
        "sample_every": integer(1, MAX_STEPS, "steps between trajectory frames"),
        "checkpoint_every": integer(1, MAX_STEPS, "a multiple of sample_every (default: steps)"),
        "transient": {"type": "number", "minimum": 0, "exclusiveMaximum": 1},
        "until": {"anyOf": [until, {"type": "null"}]},
    }, ("steps", "sample_every"))
    return {
        "$schema": "http://json-schema.org/draft-07/schema#",
        "title": "fcsweep sweep configuration",
        **obj({
            "description": {"type": "string"},
            "output": {"anyOf": [{"type": "string", "minLength": 1}, output]},
            "seed": integer(0, 2**63 - 1),
            "replicates": integer(1, MAX_RUNS),
            "grid": obj(grid_entry, minProperties=1),
            "model": {"anyOf": [obj(params), {"type": "null"}]},
            "run": run,
        }, ("output", "grid", "run")),
    }


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
    names = list(cfg.grid)
    points = []
    for k, point in enumerate(cfg.refined):
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
