"""Sweep configuration: YAML -> validated, frozen run specifications.

A sweep file has seven top-level sections (see ``results_schema.md`` and the README)::

    output: runs/phase            # or {dir: runs/phase, fields: [...], compression: gzip}
    seed: 12345
    replicates: 1
    grid: {eta: [0.01, 0.1], v0: {start: 0.01, stop: 0.06, num: 6}, N: [1024]}
    model: {density: 0.95, Dr: 0.01, dt: 0.005, modes: 6, contour_points: 40}
    run: {steps: 1000000, sample_every: 1000, checkpoint_every: 100000, transient: 0.2,
          until: {check_every: 100000, min_steps: 200000, confidence: 0.95}}   # until optional
    analysis: {label_confidence: 0.95, percolation_threshold: 0.5, correlations: auto}  # optional

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
sorted (the parameters declared ``id_omits_default`` in the table -- ``integrator``,
``initial``, ``core_exponent`` -- only when they differ from their default, ``euler``,
``lattice`` and 1, so ids
from before these keys existed are unchanged).  So ``eta: 1`` and ``eta: 1.0`` give the same run.  The
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

from fcsweep.config.errors import MAX_LISTED, UNCHECKED, ConfigError
from fcsweep.config.limits import (MAX_CELL_STEPS, MAX_DR_DT, MAX_FRAMES, MAX_RUNS, MAX_STEP_PER_R0,
                                   MAX_STEP_PER_SPACING, MAX_STEPS, check_memory, check_runnable,
                                   check_step_sizes, machine_memory_bytes, run_memory_bytes)
from fcsweep.config.params import PARAM_RANGES
from fcsweep.config.schema import json_schema
from fcsweep.config.settings import (DEFAULT_FIELDS, DEFAULT_TRANSIENT, FIELDS, MODEL_DEFAULTS, RunSettings,
                                     RunSpec, StoreSettings, SweepConfig, UntilSettings, run_id_of, seed_of)
from fcsweep.config.validate import builtin_demo_path, load_config, parse_config
from fcsweep.config.yaml12 import MAX_CONFIG_BYTES, UniqueKeyLoader
from fcsweep.model.observables import UNTIL_OBSERVABLES

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
    "DEFAULT_FIELDS",
    "DEFAULT_TRANSIENT",
    "UNCHECKED",
    "MAX_CONFIG_BYTES",
    "MAX_STEPS",
    "MAX_FRAMES",
    "MAX_CELL_STEPS",
    "MAX_STEP_PER_SPACING",
    "MAX_STEP_PER_R0",
    "MAX_DR_DT",
    "UniqueKeyLoader",
]
