"""Checks of one model parameter value against the declared table
(:data:`fcsweep.model.parameters.PARAMETERS`), and its canonical form in run ids."""

from __future__ import annotations

from typing import Any

from fcsweep.config.errors import ConfigError, as_int, as_real, show_value
from fcsweep.model.parameters import INT_PARAMS, PARAMETERS, RANGES, STR_PARAMS, value_problem

#: Closed ranges of the numeric model parameters (density: lo <= rho < 1), from the table.
PARAM_RANGES = RANGES


def allowed_values(name: str) -> str:
    """What a model parameter may be, as in the range messages (``allowed 1e-06 <= dt <= 1``)."""
    if name in STR_PARAMS:
        return f"choose one of {list(STR_PARAMS[name])}"
    if name in INT_PARAMS:  # N, modes, contour_points: their rule (the table's one wording)
        return f"allowed {PARAMETERS[name].allowed}"
    return PARAMETERS[name].range_text()


def check_param(name: str, value, where: str) -> Any:
    """Validate and canonicalise one model parameter value: its type is read here (an
    integer, a finite number, a string), everything else is the model's one check of a
    value (:func:`fcsweep.model.parameters.value_problem`), which SimParams calls too."""
    key = f"{where}.{name}"
    if name in STR_PARAMS:
        if not isinstance(value, str):
            raise ConfigError(f"{key} = {show_value(value)} is not allowed; choose one of {list(STR_PARAMS[name])}")
        parsed = value
    elif name in INT_PARAMS:
        lo, hi = PARAM_RANGES[name]
        parsed = as_int(value, key, minimum=0 if name == "modes" else int(lo), maximum=None if name == "modes"
                        else int(hi), allowed=allowed_values(name))
    else:
        parsed = as_real(value, key, allowed_values(name))
    problem = value_problem(name, parsed, key, show_value(value))
    if problem:
        raise ConfigError(problem)
    return parsed


def canon_value(name: str, value) -> Any:
    if name in INT_PARAMS:
        return int(value)
    if name in STR_PARAMS:
        return str(value)
    return repr(float(value))
