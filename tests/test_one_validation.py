"""One validation per table: :class:`fcsweep.simulation.SimParams` refuses what the config
refuses, with the config's own message (the same functions of fcsweep.model write both)."""

from __future__ import annotations

import pytest

from fcsweep.config import ConfigError, check_runnable, parse_config
from fcsweep.simulation import SimParams

BASE = {"N": 64, "eta": 0.03, "v0": 0.06}


def _config_problem(model: dict) -> str:
    """The config's first message for these model values, without the ``model.`` key prefix."""
    lines = "\n".join(f"  {k}: {v!r}" for k, v in model.items() if k != "N")
    text = (f"output: out\nseed: 1\ngrid:\n  N: [{model['N']}]\nmodel:\n{lines}\n"
            "run: {steps: 100, sample_every: 10, checkpoint_every: 50}\n")
    with pytest.raises(ConfigError) as info:
        check_runnable(parse_config(text))
    problem = info.value.problems[0] if info.value.problems else str(info.value).split(": ", 1)[1]
    return problem.replace("model.", "")


# the four cases the config refused and SimParams accepted (the rest set so that every other
# check passes: each is refused for the named reason alone)
CASES = {
    "modes above the table's 32": {"modes": 40, "contour_points": 81, "dt": 0.002},
    "eta above the table's 1e3": {"eta": 5000.0, "dt": 2e-6},
    "Dr*dt above 0.1": {"Dr": 50.0, "dt": 0.005},
    "v0*dt above the step bound": {"v0": 100.0, "dt": 0.005},
}


@pytest.mark.parametrize("case", CASES)
def test_simparams_raises_the_configs_error(case):
    values = {**BASE, **CASES[case]}
    expected = _config_problem(values)
    with pytest.raises(ValueError) as info:
        SimParams(seed=1, **values)
    assert str(info.value) == expected


def test_each_case_is_refused_for_its_own_reason():
    """The messages name the rule each case breaks (not a side effect of the filler values)."""
    words = {"modes above the table's 32": "modes = 40 is not allowed",
             "eta above the table's 1e3": "eta = 5000.0 is out of range",
             "Dr*dt above 0.1": "Dr*dt = 0.25",
             "v0*dt above the step bound": "moves a cell v0*dt = 0.5"}
    for case, fragment in words.items():
        with pytest.raises(ValueError, match=fragment.replace("*", r"\*").replace(".", r"\.")):
            SimParams(seed=1, **{**BASE, **CASES[case]})


def test_a_valid_point_passes_both():
    SimParams(seed=1, **BASE)
    text = ("output: out\nseed: 1\ngrid: {N: [64]}\nmodel: {eta: 0.03, v0: 0.06}\n"
            "run: {steps: 100, sample_every: 10}\n")
    check_runnable(parse_config(text))


def test_the_core_exponent_rule_is_stated_once():
    """SimParams, the numpy rates and the kernels' rates refuse p != 1 with the point rules with
    the one rule's message (fcsweep.model.integrators.core_exponent_problem)."""
    import numpy as np

    from fcsweep.kernels.api import kernel_rates
    from fcsweep.model.integrators import core_exponent_problem
    from fcsweep.model.lattice import hexagonal_lattice
    from fcsweep.model.rates import rates

    expected = core_exponent_problem(2.0, "binary", 6, "euler")
    assert expected.startswith("core_exponent = 2 needs quadrature 'arc'")
    with pytest.raises(ValueError) as info:
        SimParams(seed=1, **BASE, core_exponent=2.0, quadrature="binary")
    assert str(info.value) == expected
    pos, box = hexagonal_lattice(16)
    a = b = np.zeros((16, 5))
    for f in (rates, kernel_rates):
        with pytest.raises(ValueError) as info:
            f(pos, np.zeros(16), a, b, eta=0.1, v0=0.01, box=box, quadrature="binary", core_exponent=2.0)
        assert str(info.value) == expected, f.__module__
