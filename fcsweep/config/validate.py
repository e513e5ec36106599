"""YAML text -> validated :class:`~fcsweep.config.settings.SweepConfig`, every problem
of a file reported at once."""

from __future__ import annotations

import os
from collections import Counter
from pathlib import Path
from typing import Any, Mapping

import numpy as np
import yaml

from fcsweep.config.errors import (FAILED, UNCHECKED, ConfigError, ConfigProblems, as_int, as_real, show_value,
                                   unknown_key)
from fcsweep.config.limits import (MAX_RUNS, MAX_STEPS, check_output_path, check_run_count,
                                   check_run_length)
from fcsweep.config.params import PARAM_RANGES, allowed_values, canon_value, check_param
from fcsweep.config.settings import (ANALYSIS_KEYS, COMPRESSIONS, DEFAULT_FIELDS,
                                     DEFAULT_TRANSIENT, FIELDS, MODEL_DEFAULTS, OUTPUT_KEYS,
                                     RANGE_KEYS, RUN_KEYS, TOP_KEYS, UNTIL_CONFIDENCE,
                                     UNTIL_KEYS, AnalysisSettings, RunSettings, StoreSettings, SweepConfig,
                                     UntilSettings)
from fcsweep.model.observables import UNTIL_OBSERVABLES
from fcsweep.config.yaml12 import MAX_CONFIG_BYTES, MAX_NESTING, check_structure, read_text, UniqueKeyLoader
from fcsweep.model.parameters import INT_PARAMS, STR_PARAMS
from fcsweep.model.settings import SETTINGS, setting_problem


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
    return parse_config(read_text(path), source=str(path)).with_refinement()


def parse_config(text: str, source: str = "<string>") -> SweepConfig:
    """Validate a sweep given as YAML text. See :func:`load_config` (unlike it, no
    refinement points are read: :meth:`SweepConfig.with_refinement` adds them)."""
    if len(text) > MAX_CONFIG_BYTES:
        raise ConfigError(f"{source}: {len(text)} characters; a sweep file has at most {MAX_CONFIG_BYTES}")
    try:
        data = yaml.load(text, Loader=UniqueKeyLoader)
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
        check_structure(data)
        return _validate(data, source)
    except ConfigError as exc:
        raise exc.with_source(source) from None
    except (ArithmeticError, TypeError, ValueError, RecursionError) as exc:  # a check missed: still no traceback
        raise ConfigError(f"{source}: {UNCHECKED} ({type(exc).__name__}: {exc})") from None


def _grid_values(name: str, spec, problems: ConfigProblems | None = None):
    """The values of one grid entry, each checked as a model parameter; its problems go
    to ``problems`` (then :data:`FAILED` is returned) or are raised."""
    local = ConfigProblems() if problems is None else problems
    first = local.count
    values = _grid_raw_values(name, spec, local)
    if values is not FAILED:
        is_range = isinstance(spec, Mapping)
        out = []
        for v in values:
            x = local.attempt(check_param, name, v, "grid")
            if x is FAILED and is_range:  # one message for a range, not one per value
                break
            out.append(x)
        if local.count == first:
            canon = Counter(canon_value(name, v) for v in out)
            if len(canon) != len(out):
                dup = next(c for c, n in canon.items() if n > 1)
                local.add(ConfigError(f"grid.{name} = {show_value(list(values))} repeats the value {dup}; "
                                      "each value once"))
            values = tuple(out)
    if problems is None:
        local.raise_if_any()
    return values if local.count == first else FAILED


def _grid_raw_values(name: str, spec, problems: ConfigProblems):
    """The unchecked values of a grid entry (a range expanded), or :data:`FAILED`."""
    key = f"grid.{name}"
    if isinstance(spec, Mapping):
        first = problems.count
        suggested = problems.keys(spec, RANGE_KEYS, f"in {key}: ")
        missing = [k for k in ("start", "stop", "num") if k not in spec]
        if [k for k in missing if k not in suggested]:
            problems.add(ConfigError(
                f"{key} = {show_value(dict(spec))} is missing {missing}; a range is {{start, stop, num[, log]}}"))
        if missing:
            return FAILED
        allowed = allowed_values(name) if name in PARAM_RANGES else None
        start = problems.attempt(as_real, spec["start"], f"{key}.start", allowed)
        stop = problems.attempt(as_real, spec["stop"], f"{key}.stop", allowed)
        num = problems.attempt(as_int, spec["num"], f"{key}.num", minimum=1, maximum=MAX_RUNS)
        log = spec.get("log", False)
        if not isinstance(log, bool):
            problems.add(ConfigError(f"{key}.log = {show_value(log)} must be true or false"))
        if name in STR_PARAMS:
            problems.add(ConfigError(f"{key} = {show_value(dict(spec))}: {name} takes a list of names, not a range"))
        if problems.count > first:
            return FAILED
        if log:
            if start <= 0 or stop <= 0:
                problems.add(ConfigError(
                    f"{key} = {show_value(dict(spec))}: a log range needs start > 0 and stop > 0"))
                return FAILED
            values = np.geomspace(start, stop, num)
        else:
            values = np.linspace(start, stop, num)
        # 12 significant digits: linspace(0.01, 0.06, 6) gives 0.03, not 0.030000000000000002
        values = [float(f"{v:.12g}") for v in values]
        if name in INT_PARAMS:
            if any(not float(v).is_integer() for v in values):
                problems.add(ConfigError(
                    f"{key} = {show_value(dict(spec))} gives non-integer values {values}; "
                    f"{name} must be integers (use a list)"))
                return FAILED
            values = [int(v) for v in values]
        return values
    if isinstance(spec, (list, tuple)):
        if len(spec) == 0:
            problems.add(ConfigError(f"{key} = [] is empty; give at least one value"))
            return FAILED
        return list(spec)
    if isinstance(spec, (str, int, float)) and not isinstance(spec, bool):
        return [spec]
    problems.add(ConfigError(f"{key} = {show_value(spec)} must be a list of values or {{start, stop, num}}"))
    return FAILED


def _validate(data, source: str) -> SweepConfig:
    """The validated config, or one ConfigError listing every problem of ``data``."""
    if data is None:
        raise ConfigError("the file is empty; a sweep needs at least 'grid' and 'run'")
    if not isinstance(data, Mapping):
        raise ConfigError(f"top level must be a mapping of sections, got {type(data).__name__}")
    problems = ConfigProblems()
    suggested = problems.keys(data, TOP_KEYS, "")
    for req in ("output", "grid", "run"):
        if req not in data and req not in suggested:
            problems.add(ConfigError(f"missing required section {req!r}"))

    out = _output_section(data["output"], problems) if "output" in data else FAILED
    seed = problems.attempt(_seed, data.get("seed", 0))
    replicates = problems.attempt(as_int, data.get("replicates", 1), "replicates", minimum=1, maximum=MAX_RUNS)
    description = data.get("description", "")
    if not isinstance(description, str):
        problems.add(ConfigError(f"description = {show_value(description)} must be a string"))

    # grid
    grid, swept, log_axes = FAILED, set(), ()
    grid_in = data.get("grid")
    grid_named = isinstance(grid_in, Mapping) and len(grid_in) > 0  # so missing parameters are meaningful
    if "grid" in data:
        if not isinstance(grid_in, Mapping):
            problems.add(ConfigError(f"grid = {show_value(grid_in)} must be a mapping of parameter -> values"))
        elif len(grid_in) == 0:
            problems.add(ConfigError("grid = {} is empty; sweep at least one model parameter"))
        else:
            first = problems.count
            suggested = problems.keys(grid_in, list(MODEL_DEFAULTS), "in grid: ")
            known = {k: v for k, v in grid_in.items() if k in MODEL_DEFAULTS}
            swept = set(known) | suggested
            counted = problems.attempt(check_run_count, known, 1 if replicates is FAILED else replicates)
            if counted is not FAILED:  # expand nothing that may be huge
                grid = {str(k): _grid_values(str(k), v, problems) for k, v in known.items()}
                log_axes = tuple(str(k) for k, v in known.items() if isinstance(v, Mapping) and v.get("log") is True)
            if problems.count > first:
                grid = FAILED

    model = _model_section(data.get("model") or {}, swept, grid_named, problems)
    run = _run_section(data["run"], problems) if "run" in data else FAILED
    analysis = _analysis_section(data.get("analysis") or {}, problems)
    if analysis is not FAILED and run is not FAILED and run.until is not None \
            and run.until.confidence < analysis.label_confidence:
        problems.add(ConfigError(
            f"run.until.confidence = {run.until.confidence!r} is below analysis.label_confidence = "
            f"{analysis.label_confidence!r}; a run may stop only when its labels are decided at the label "
            "confidence: raise run.until.confidence or lower analysis.label_confidence"))
    if not any(x is FAILED for x in (run, grid, model)):
        problems.attempt(check_run_length, run, grid, model)
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
        analysis=analysis,
    )


def _seed(value) -> int:
    seed = as_int(value, "seed", minimum=0, allowed="allowed 0 <= seed < 2**63")
    if seed >= 2**63:
        raise ConfigError(f"seed = {seed} is out of range; allowed 0 <= seed < 2**63")
    return seed


def _output_section(out, problems: ConfigProblems):
    """``(output directory, StoreSettings)`` of the ``output`` section, or :data:`FAILED`."""
    first = problems.count
    store = StoreSettings()
    if isinstance(out, Mapping):
        problems.keys(out, OUTPUT_KEYS, "in output: ")
        fields = out.get("fields", list(DEFAULT_FIELDS))
        if not isinstance(fields, (list, tuple)) or not all(isinstance(f, str) for f in fields):
            problems.add(ConfigError(f"output.fields = {show_value(fields)} must be a list of names from "
                                     f"{list(FIELDS)}"))
        else:
            for f in fields:
                if f not in FIELDS:
                    problems.add(unknown_key(f, FIELDS, "in output.fields: "))
            fields = tuple(f for f in FIELDS if f in set(fields) | {"position", "image"})
        comp = out.get("compression", "gzip")
        if comp not in COMPRESSIONS:
            problems.add(ConfigError(
                f"output.compression = {show_value(comp)} is not allowed; choose one of {list(COMPRESSIONS)}"))
        level = problems.attempt(as_int, out.get("compression_level", 4), "output.compression_level", minimum=0,
                                 allowed="allowed 0..9")
        if level is not FAILED and level > 9:
            problems.add(ConfigError(f"output.compression_level = {level} is out of range; allowed 0..9"))
        if "dir" not in out:
            problems.add(ConfigError("output.dir is missing; give the sweep directory"))
            return FAILED
        if problems.count == first:
            store = StoreSettings(fields=fields, compression=comp, compression_level=level)
        out = out["dir"]
    if not isinstance(out, str) or not out.strip():
        problems.add(ConfigError(f"output = {show_value(out)} must be a directory path (string)"))
    else:
        problems.attempt(check_output_path, out)
    if problems.count > first:
        return FAILED
    return Path(os.path.expanduser(out)), store


def _model_section(model_in, swept: set, grid_named: bool, problems: ConfigProblems):
    """The fixed model parameters, defaults filled in, or :data:`FAILED`.

    ``swept``: the grid's parameters (and those a misspelled grid key suggests);
    ``grid_named``: whether the grid is a non-empty mapping, so that a parameter in
    neither place is missing (and not a consequence of a broken grid).
    """
    if not isinstance(model_in, Mapping):
        problems.add(ConfigError(f"model = {show_value(model_in)} must be a mapping of parameter -> value"))
        return FAILED
    first = problems.count
    suggested = problems.keys(model_in, list(MODEL_DEFAULTS), "in model: ")
    model: dict[str, Any] = {}
    for name, default in MODEL_DEFAULTS.items():
        if name in swept:
            if name in model_in:
                problems.add(ConfigError(
                    f"model.{name} = {show_value(model_in[name])} is also swept in grid.{name}; "
                    "give it in one place only"))
            continue
        if name in model_in:
            model[name] = problems.attempt(check_param, name, model_in[name], "model")
        elif default is None:
            if grid_named and name not in suggested:
                problems.add(ConfigError(f"model parameter {name!r} is missing; give it in 'model' or 'grid'"))
            model[name] = FAILED
        else:
            model[name] = default
    return model if problems.count == first and FAILED not in model.values() else FAILED


def _analysis_section(analysis_in, problems: ConfigProblems):
    """The :class:`AnalysisSettings` of the ``analysis`` section, or :data:`FAILED`."""
    if not isinstance(analysis_in, Mapping):
        problems.add(ConfigError(f"analysis = {show_value(analysis_in)} must be a mapping with keys "
                                 f"{', '.join(ANALYSIS_KEYS)}"))
        return FAILED
    first = problems.count
    problems.keys(analysis_in, ANALYSIS_KEYS, "in analysis: ")
    values = {}
    for name in ANALYSIS_KEYS:
        if name not in analysis_in:
            continue
        key, value = f"analysis.{name}", analysis_in[name]
        if SETTINGS[name].type in (float, "float"):
            value = problems.attempt(as_real, value, key, f"allowed {SETTINGS[name].allowed}")
        if value is FAILED:
            continue
        problem = setting_problem(name, value, key)
        if problem:
            problems.add(ConfigError(problem))
        else:
            values[name] = value
    if problems.count > first:
        return FAILED
    return AnalysisSettings(**values)


def _run_section(run_in, problems: ConfigProblems):
    """The :class:`RunSettings` of the ``run`` section, or :data:`FAILED`."""
    if not isinstance(run_in, Mapping):
        problems.add(ConfigError(f"run = {show_value(run_in)} must be a mapping"))
        return FAILED
    first = problems.count
    suggested = problems.keys(run_in, RUN_KEYS, "in run: ")
    for req in ("steps", "sample_every"):
        if req not in run_in and req not in suggested:
            problems.add(ConfigError(f"run.{req} is missing"))
    steps = sample_every = checkpoint_every = FAILED
    if "steps" in run_in:
        steps = problems.attempt(as_int, run_in["steps"], "run.steps", minimum=1, maximum=MAX_STEPS)
    if "sample_every" in run_in:
        sample_every = problems.attempt(as_int, run_in["sample_every"], "run.sample_every", minimum=1,
                                        maximum=MAX_STEPS)
    if steps is not FAILED and sample_every is not FAILED and steps % sample_every:
        problems.add(ConfigError(
            f"run.steps = {steps} is not a multiple of run.sample_every = {sample_every}; "
            "steps must be a whole number of frames"))
    if "checkpoint_every" in run_in or steps is not FAILED:
        checkpoint_every = problems.attempt(as_int, run_in.get("checkpoint_every", steps), "run.checkpoint_every",
                                            minimum=1, maximum=MAX_STEPS)
    if checkpoint_every is not FAILED and sample_every is not FAILED and checkpoint_every % sample_every:
        problems.add(ConfigError(
            f"run.checkpoint_every = {checkpoint_every} is not a multiple of run.sample_every = "
            f"{sample_every}; checkpoints are taken on frame boundaries"))
    transient = problems.attempt(as_real, run_in.get("transient", DEFAULT_TRANSIENT), "run.transient",
                                 f"allowed {SETTINGS['transient'].allowed}")
    if transient is not FAILED and setting_problem("transient", transient):
        problems.add(ConfigError(setting_problem("transient", transient, "run.transient")))
        transient = FAILED
    until = None
    if run_in.get("until") is not None:
        if problems.count > first:  # until's bounds refer to steps and checkpoint_every
            return FAILED
        until = _until(run_in["until"], steps, sample_every, checkpoint_every, problems)
    if problems.count > first:
        return FAILED
    return RunSettings(steps, sample_every, checkpoint_every, transient, until)


def _until(until_in, steps: int, sample_every: int, checkpoint_every: int,
           problems: ConfigProblems | None = None) -> UntilSettings:
    """Validate ``run.until``; every message names the key and its allowed range.

    Problems go to ``problems`` (then :data:`FAILED` is returned) or are raised."""
    local = ConfigProblems() if problems is None else problems
    first = local.count
    result = _until_settings(until_in, steps, checkpoint_every, local)
    if problems is None:
        local.raise_if_any()
    return result if local.count == first else FAILED


def _until_settings(until_in, steps: int, checkpoint_every: int, problems: ConfigProblems):
    if not isinstance(until_in, Mapping):
        problems.add(ConfigError(f"run.until = {until_in!r} must be a mapping with keys {', '.join(UNTIL_KEYS)}"))
        return FAILED
    suggested = problems.keys(until_in, UNTIL_KEYS, "in run.until: ")
    check_every = FAILED
    if "check_every" not in until_in:
        if "check_every" not in suggested:
            problems.add(ConfigError(
                f"run.until.check_every is missing; give the steps between checks, a multiple of "
                f"run.checkpoint_every = {checkpoint_every} and at most run.steps = {steps}"))
    else:
        check_every = problems.attempt(as_int, until_in["check_every"], "run.until.check_every", minimum=1,
                                       allowed=f"allowed a multiple of run.checkpoint_every = {checkpoint_every}, "
                                               f"at most run.steps = {steps}")
        if check_every is not FAILED and (check_every % checkpoint_every or check_every > steps):
            problems.add(ConfigError(
                f"run.until.check_every = {check_every} is not allowed; it must be a multiple of "
                f"run.checkpoint_every = {checkpoint_every} (checks happen at checkpoints) and at most "
                f"run.steps = {steps}"))
            check_every = FAILED
    min_steps = FAILED
    if "min_steps" in until_in or check_every is not FAILED:
        min_steps = problems.attempt(as_int, until_in.get("min_steps", check_every), "run.until.min_steps", minimum=0,
                                     allowed=f"allowed 0 <= min_steps <= run.steps = {steps}")
    if min_steps is not FAILED and min_steps > steps:
        problems.add(ConfigError(f"run.until.min_steps = {min_steps} is out of range; allowed 0 <= min_steps <= "
                                 f"run.steps = {steps}"))
    confidence = problems.attempt(as_real, until_in.get("confidence", UNTIL_CONFIDENCE), "run.until.confidence",
                                  "allowed 0.5 <= confidence < 1")
    if confidence is not FAILED and not 0.5 <= confidence < 1.0:
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
                x = problems.attempt(as_real, rel_in[name], f"run.until.rel_error.{name}", "allowed 0 < target <= 1")
                if x is not FAILED and not 0.0 < x <= 1.0:
                    problems.add(ConfigError(
                        f"run.until.rel_error.{name} = {x!r} is out of range; allowed 0 < target <= 1 "
                        "(1-sigma error / |value|)"))
                rel.append((name, x))
    if FAILED in (check_every, min_steps, confidence) or any(x is FAILED for _, x in rel):
        return FAILED
    return UntilSettings(check_every, min_steps, confidence, tuple(rel))
