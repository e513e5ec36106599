"""The validated sweep: its settings, its runs and their identity (ids and seeds)."""

from __future__ import annotations

import dataclasses
import hashlib
import itertools
import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from fcsweep.config.errors import ConfigError
from fcsweep.config.params import canon_value, check_param
from fcsweep.model.parameters import DEFAULTS, ID_OMITS_DEFAULT
from fcsweep.model.settings import (CONFIG_KEYS, CORRELATIONS, DEFAULT_CORRELATIONS, DEFAULT_TRANSIENT,  # noqa: F401
                                    LABEL_CONFIDENCE, PERCOLATION_THRESHOLD, AnalysisSettings)

#: Model parameters and their defaults (:data:`fcsweep.model.parameters.PARAMETERS`); ``None`` means "must be given".
MODEL_DEFAULTS: dict[str, Any] = DEFAULTS

#: Per-cell time series that ``output.fields`` may select (position and image always stored).
FIELDS = ("position", "image", "theta", "shape_a", "shape_b")
DEFAULT_FIELDS = FIELDS
COMPRESSIONS = ("gzip", "lzf", "none")

TOP_KEYS = ("output", "seed", "replicates", "grid", "model", "run", "analysis", "description")
RUN_KEYS = ("steps", "sample_every", "checkpoint_every", "transient", "until")
UNTIL_KEYS = ("check_every", "min_steps", "confidence", "rel_error")
#: Default ``run.until.confidence``: both labels at 95 % probability.
UNTIL_CONFIDENCE = 0.95
#: The keys of the ``analysis`` section: settings of the one table of analysis settings
#: (:class:`fcsweep.model.settings.AnalysisSettings`, whose defaults these are).
ANALYSIS_KEYS = CONFIG_KEYS
#: Largest N that ``auto`` gives the pair counts: the paper's largest N, so that the analyses of
#: the paper's sizes stay those of the reference.  Above it the pair query out to half the box
#: holds ~0.4 N^2 pairs (15 GB of peak memory at N = 16384), the FFT grid O(N).
PAIRS_MAX_N = 10000


def correlation_method(requested: str, N: int) -> str:
    """``pairs`` or ``fft``: the method ``analysis.correlations = requested`` uses for ``N`` cells."""
    if requested == "auto":
        return "pairs" if int(N) <= PAIRS_MAX_N else "fft"
    if requested not in CORRELATIONS:
        raise ValueError(f"correlations = {requested!r}; allowed: {', '.join(CORRELATIONS)}")
    return requested


def settings_for_run(settings: dict | None, N: int) -> dict | None:
    """Analysis settings as one run of ``N`` cells is analysed and stored, with
    ``correlations`` resolved by :func:`correlation_method`.

    An absent key means ``auto``.  The key is left out where the method is ``pairs`` at
    ``N <= PAIRS_MAX_N`` (what ``auto`` gives there, and what files written before the key
    existed hold) and written out otherwise, so that a stored pair-count analysis of more
    cells reads as made with other settings and is recomputed.  ``None`` stays ``None``.
    """
    if settings is None:
        return None
    out = dict(settings)
    method = correlation_method(out.pop("correlations", DEFAULT_CORRELATIONS), N)
    if method == "fft" or int(N) > PAIRS_MAX_N:
        out["correlations"] = method
    return out
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
    transient: float = DEFAULT_TRANSIENT
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
        """Keyword arguments of :meth:`Simulation.create` (without ``N``)."""
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
    analysis : AnalysisSettings
        The ``analysis`` section (label confidence, percolation threshold, correlations; the
        other analysis settings at their defaults).
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
    analysis: AnalysisSettings = field(default_factory=AnalysisSettings)

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
            "analysis": self.analysis.config_dict(),
            "description": self.description,
        }


def run_id_of(params: Mapping[str, Any], replicate: int) -> str:
    """Stable 12-hex-digit id of a run from its model parameters and replicate.

    ``seed`` (if present in ``params``) is ignored: the seed derives from the id, and so
    is every parameter declared ``id_omits_default`` (``integrator``, ``initial``) when it
    has its default value (ids from before the key existed hold).
    """
    canon = {k: canon_value(k, v) for k, v in params.items()
             if k != "seed" and not (k in ID_OMITS_DEFAULT and v == ID_OMITS_DEFAULT[k])}
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
        points.append(tuple(check_param(n, point[n], "refinement") for n in names))
    specs = []
    index = 0
    seen = set()
    for combo in itertools.chain(itertools.product(*(cfg.grid[n] for n in names)), points):
        key = tuple(canon_value(n, v) for n, v in zip(names, combo))
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
