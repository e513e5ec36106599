"""The harder core: energy sum_{i<j} A_ij^p + eta sum_i P_i (``core_exponent`` p).

Kernel against its numpy twin (which takes A from the independent exact overlap of
:mod:`fcsweep.model.overlap_exact`), the force law of two overlapping cells, p = 1 left
bit for bit as it was, and the configuration checks.
"""

import math

import numpy as np
import pytest

from conftest import dense_config
from fcsweep.config import ConfigError, parse_config
from fcsweep.config.settings import run_id_of
from fcsweep.kernels.api import kernel_rates
from fcsweep.model.parameters import DEFAULTS, ID_OMITS_DEFAULT
from fcsweep.model.discs import lens_area
from fcsweep.model.rates import rates

KEYS = ("dpos", "dtheta", "da", "db")


def _max_rel(r1, r2):
    worst = 0.0
    for k in KEYS:
        if r1[k].size:
            scale = max(1.0, np.abs(r1[k]).max())
            worst = max(worst, np.abs(r1[k] - r2[k]).max() / scale)
    return worst


@pytest.mark.parametrize("N,p", [(16, 2.0), (64, 1.5), (64, 3.0)])
def test_kernel_equals_twin_with_core_exponent(N, p):
    """The kernel's pair areas come from its contact arcs (two Gauss points per panel of
    at most the contour spacing h: error h^5/4320 times the 4th derivative of R^2, ~1e-6
    R0^2 per panel with modes up to 6 at this deformation, i.e. ~1e-4 of overlap areas of
    ~0.02); the twin's from the converged exact overlap.  So the rates agree to 2e-3 of
    their scale, not to round-off as at p = 1; N = 16 takes the all-image path, N = 64
    the neighbour list."""
    pos, theta, a, b, box = dense_config(N, seed=3 + N, deform=0.12)
    kw = dict(eta=0.05, v0=0.03, box=box, contour_points=40, quadrature="arc", core_exponent=p)
    twin = rates(pos, theta, a, b, **kw)
    kern = kernel_rates(pos, theta, a, b, **kw)
    assert _max_rel(twin, kern) < 2e-3
    # and p really changes the rates (overlap areas here are ~0.01-0.1 R0^2)
    plain = kernel_rates(pos, theta, a, b, **{**kw, "core_exponent": 1.0})
    assert _max_rel(plain, kern) > 1e-2


@pytest.mark.parametrize("p", [1.0, 1.5, 2.0, 3.0])
@pytest.mark.parametrize("modes", [0, 6])
def test_two_circles_feel_p_A_to_the_p_minus_1_times_the_chord(p, modes):
    """Two circles at distance d < 2 R0: A = lens area, dA/dd = -chord, so the energy A^p
    pushes each with F = p A^(p-1) chord along the line of centres.  Rigid discs are
    exact to round-off; contour cells (arc rule) to the arc's area error."""
    M1 = max(modes - 1, 0)
    z = np.zeros((2, M1))
    forces = []
    for d in (1.2, 1.5, 1.8, 1.95):
        r = kernel_rates(np.array([[0.0, 0.0], [d, 0.0]]), np.zeros(2), z, z, eta=0.0, v0=0.0, core_exponent=p)
        chord = 2.0 * math.sqrt(1.0 - d * d / 4.0)
        expect = p * lens_area(d) ** (p - 1.0) * chord
        assert r["dpos"][0, 0] == pytest.approx(-expect, rel=1e-12 if modes == 0 else 1e-6)
        assert r["dpos"][1, 0] == pytest.approx(expect, rel=1e-12 if modes == 0 else 1e-6)
        assert abs(r["dpos"][0, 1]) < 1e-9
        forces.append(-r["dpos"][0, 0])
    # the harder the core, the faster the force falls off towards first contact
    if p > 1:
        assert forces[-1] / forces[0] < 2.0 * math.sqrt(1 - 1.95 ** 2 / 4) / (2.0 * math.sqrt(1 - 1.2 ** 2 / 4))


def test_p_equal_1_is_bit_identical_and_keeps_run_ids():
    """p = 1 given explicitly is the default path: same rates to the bit, same short
    trajectory to the bit, and the run id does not change (the key is left out at 1)."""
    from fcsweep.simulation import Simulation

    pos, theta, a, b, box = dense_config(64, seed=11)
    kw = dict(eta=0.05, v0=0.03, box=box, quadrature="arc")
    r0 = kernel_rates(pos, theta, a, b, **kw)
    r1 = kernel_rates(pos, theta, a, b, core_exponent=1.0, **kw)
    for k in KEYS:
        assert np.array_equal(r0[k], r1[k])
    runs = []
    for extra in ({}, {"core_exponent": 1.0}):
        sim = Simulation.create(16, seed=5, eta=0.05, v0=0.05, quadrature="arc", **extra)
        sim.advance(40)
        runs.append(sim.state)
    for name in ("pos", "theta", "a", "b", "image"):
        assert np.array_equal(getattr(runs[0], name), getattr(runs[1], name))
    params = {**{k: v for k, v in DEFAULTS.items() if v is not None}, "N": 64, "eta": 0.05, "v0": 0.03}
    assert ID_OMITS_DEFAULT["core_exponent"] == 1.0
    old = {k: v for k, v in params.items() if k != "core_exponent"}
    assert run_id_of(params, 0) == run_id_of(old, 0)
    assert run_id_of({**params, "core_exponent": 2.0}, 0) != run_id_of(old, 0)


def test_harder_core_relaxes_without_raising_the_energy():
    """v0 = D_r = 0: the dynamics descend sum A^p + eta sum P (p = 2, rigid discs: exact
    lens areas; a jittered lattice at area fraction 0.95, so the discs overlap unevenly),
    so the energy never rises over the run."""
    from fcsweep.simulation import SimParams, Simulation, State

    p = SimParams(N=16, seed=2, eta=0.0, v0=0.0, Dr=0.0, modes=0, core_exponent=2.0)
    pos, _, _, _, box = dense_config(16, seed=2, M1=0, jitter=0.15)
    z = np.zeros((16, 0))
    sim = Simulation(p, State(pos=pos, image=np.zeros((16, 2), np.int64), theta=np.zeros(16), a=z, b=z,
                              box=np.asarray(box, float)), np.random.default_rng(0))

    def energy():
        pos, box = sim.state.pos, sim.state.box
        e = 0.0
        for i in range(len(pos)):
            d = pos - pos[i]
            d -= np.round(d / box) * box
            dist = np.hypot(d[:, 0], d[:, 1])
            e += sum(lens_area(x) ** 2 for j, x in enumerate(dist) if j > i and x < 2.0)
        return e

    values = [energy()]
    for _ in range(10):
        sim.advance(20)
        values.append(energy())
    assert values[0] > 0
    assert all(b <= a * (1 + 1e-12) for a, b in zip(values, values[1:]))
    assert values[-1] < values[0]


def _config(tmp_path, model):
    import yaml

    return parse_config(yaml.safe_dump({"output": str(tmp_path / "out"), "seed": 1, "grid": {"v0": [0.03]},
                                        "model": {"N": 16, "eta": 0.05, **model},
                                        "run": {"steps": 10, "sample_every": 5}}))


def test_config_checks_name_the_key(tmp_path):
    from fcsweep.config import check_runnable

    with pytest.raises(ConfigError, match="core_exponent"):
        _config(tmp_path, {"core_exponent": 0.5})
    with pytest.raises(ConfigError, match="core_exponent"):
        _config(tmp_path, {"core_exponent": 5.0})
    with pytest.raises(ConfigError, match="core_exponent.*arc"):
        check_runnable(_config(tmp_path, {"core_exponent": 2.0, "quadrature": "binary"}))
    with pytest.raises(ConfigError, match="core_exponent.*euler"):
        check_runnable(_config(tmp_path, {"core_exponent": 2.0, "integrator": "contact-implicit"}))
    check_runnable(_config(tmp_path, {"core_exponent": 2.0}))
    check_runnable(_config(tmp_path, {"core_exponent": 2.0, "quadrature": "binary", "modes": 0}))
