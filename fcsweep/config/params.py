"""Checks of one model parameter value against the declared table
(:data:`fcsweep.model.parameters.PARAMETERS`), and its canonical form in run ids."""

from __future__ import annotations

from typing import Any

from fcsweep.config.errors import ConfigError, as_int, as_real, show_value
from fcsweep.model.parameters import INT_PARAMS, PARAMETERS, RANGES, SIGNS, STR_PARAMS

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
    """Validate and canonicalise one model parameter value."""
    key = f"{where}.{name}"
    if name in STR_PARAMS:
        if not isinstance(value, str) or value not in STR_PARAMS[name]:
            raise ConfigError(f"{key} = {show_value(value)} is not allowed; choose one of {list(STR_PARAMS[name])}")
        return value
    if name == "N":
        lo, hi = PARAM_RANGES["N"]
        n = as_int(value, key, minimum=int(lo), maximum=int(hi), allowed=allowed_values("N"))
        from fcsweep.model.lattice import lattice_side

        try:
            lattice_side(n)
        except ValueError as exc:
            raise ConfigError(f"{key} = {value!r}: {exc}") from None
        return n
    if name == "modes":
        m = as_int(value, key, minimum=0, allowed=allowed_values("modes"))
        if m == 1 or m > PARAM_RANGES["modes"][1]:
            raise ConfigError(f"{key} = {m} is not allowed; modes is {PARAMETERS['modes'].allowed}")
        return m
    if name == "contour_points":
        lo, hi = PARAM_RANGES["contour_points"]
        return as_int(value, key, minimum=int(lo), maximum=int(hi), allowed=allowed_values("contour_points"))
    x = as_real(value, key, allowed_values(name))
    p = PARAMETERS[name]
    if not p.sign_ok(x):
        raise ConfigError(f"{key} = {value!r} is out of range; {name} must {SIGNS[p.sign][1]}")
    return _check_range(name, x, key)


def _check_range(name: str, value, key: str):
    """``value`` if it lies in the declared range of ``name`` (unknown names pass)."""
    p = PARAMETERS.get(name)
    if p is None or p.range is None or p.in_range(value):
        return value
    raise ConfigError(f"{key} = {show_value(value)} is out of range; {p.range_text()}")


def canon_value(name: str, value) -> Any:
    if name in INT_PARAMS:
        return int(value)
    if name in STR_PARAMS:
        return str(value)
    return repr(float(value))
