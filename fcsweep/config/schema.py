"""JSON Schema of a sweep file, generated from the tables the validation uses."""

from __future__ import annotations

from typing import Any

from fcsweep.config.limits import MAX_RUNS, MAX_STEPS
from fcsweep.config.params import allowed_values
from fcsweep.config.settings import COMPRESSIONS, CORRELATIONS, FIELDS, MODEL_DEFAULTS
from fcsweep.model.observables import UNTIL_OBSERVABLES
from fcsweep.model.parameters import INT_PARAMS, PARAMETERS, STR_PARAMS


def _param_schema(name: str) -> dict[str, Any]:
    """JSON Schema of one model parameter value, from its row of the parameter table."""
    doc = {"description": f"{PARAMETERS[name].doc}; {allowed_values(name)}"}
    if name in STR_PARAMS:
        return {**doc, "type": "string", "enum": list(STR_PARAMS[name])}
    lo, hi = PARAMETERS[name].range
    if name in INT_PARAMS:
        schema = {"type": "integer", "minimum": lo, "maximum": hi}
        if name == "modes":
            schema["not"] = {"const": 1}
        return {**doc, **schema}
    upper = "exclusiveMaximum" if PARAMETERS[name].upper_open else "maximum"
    return {**doc, "type": "number", "minimum": lo, upper: hi}


def json_schema() -> dict[str, Any]:
    """JSON Schema (draft-07) of a sweep YAML file, for editors' YAML language servers.

    Generated from the tables the validation uses (:data:`fcsweep.model.parameters.PARAMETERS`, the allowed keys
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
            "analysis": obj({
                "label_confidence": {"type": "number", "exclusiveMinimum": 0.5, "exclusiveMaximum": 1,
                                     "description": "probability a label needs (default 0.95)"},
                "percolation_threshold": {"type": "number", "exclusiveMinimum": 0, "exclusiveMaximum": 1,
                                          "description": "rho_d above it is percolated (default 0.5)"},
                "correlations": {"enum": list(CORRELATIONS),
                                 "description": "G6, C_G1, G_r by pair counts or by FFT (default pairs)"},
            }),
        }, ("output", "grid", "run")),
    }
