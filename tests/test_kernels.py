"""Numba kernels against their numpy twin (fcsweep.model.rates), and kernel helpers."""

import math

import numpy as np
import pytest

from conftest import dense_config
from fcsweep.kernels.api import kernel_rates
from fcsweep.kernels.geometry import atan2_fast
from fcsweep.model.rates import rates

KEYS = ("dpos", "dtheta", "da", "db")


def assert_same(r1, r2, tol=1e-11):
    for k in KEYS:
        if r1[k].size == 0:
            assert r2[k].size == 0
            continue
        scale = max(1.0, np.abs(r1[k]).max())
        assert np.abs(r1[k] - r2[k]).max() <= tol * scale, k


@pytest.mark.parametrize("quadrature", ["binary", "linear", "arc"])
@pytest.mark.parametrize("N,M1,deform", [(16, 5, 0.1), (144, 5, 0.15), (64, 7, 0.2), (36, 1, 0.3), (64, 5, 0.8)])
def test_kernel_equals_numpy_twin(quadrature, N, M1, deform):
    """Windows, neighbour lists (N >= 64), all-image path (N = 16, 36), generic M (M1 = 7)
    and shapes at the admissibility bound (0.8 of 0.816) give the twin's rates to
    round-off.  The arc twin finds the Hermite roots with numpy.roots instead of the
    kernel's safeguarded Newton iteration, so this also checks the root finding."""
    pos, theta, a, b, box = dense_config(N, seed=N + M1, deform=deform, M1=M1)
    kw = dict(eta=0.05, v0=0.03, box=box, contour_points=40, quadrature=quadrature)
    assert_same(rates(pos, theta, a, b, **kw), kernel_rates(pos, theta, a, b, **kw))


def test_kernel_equals_twin_with_open_boundaries_and_other_K():
    """K = 24, 64 take the folded mode sums (K divisible by 4), K = 30 the plain ones."""
    pos, theta, a, b, _ = dense_config(16, seed=5)
    for K in (24, 30, 64):
        kw = dict(eta=0.02, v0=0.0, box=None, contour_points=K, quadrature="binary")
        assert_same(rates(pos, theta, a, b, **kw), kernel_rates(pos, theta, a, b, **kw))


def test_pair_buffer_is_allocated_for_the_arc_rule_only():
    """Binary and linear workspaces carry no pair buffer and give the same rates as one
    that has it; the arc rule refuses a workspace without it (it would write past it)."""
    from fcsweep.kernels.workspace import Workspace, workspace_for

    pos, theta, a, b, box = dense_config(144, seed=3)
    for quad in ("binary", "linear"):
        ws = workspace_for(144, 40, a.shape[1], box, 1.0, quad)
        assert ws.nl[5].shape[0] == 0
        kw = dict(eta=0.05, v0=0.03, box=box, quadrature=quad)
        assert_same(kernel_rates(pos, theta, a, b, workspace=ws, **kw), kernel_rates(pos, theta, a, b, **kw), 0.0)
    assert workspace_for(144, 40, a.shape[1], box, 1.0, "arc").nl[5].shape[0] == 144 * 16
    with pytest.raises(ValueError, match="pair_buffer"):
        kernel_rates(pos, theta, a, b, eta=0.05, v0=0.03, box=box, quadrature="arc",
                     workspace=Workspace(144, 40, a.shape[1], box, pair_buffer=False))


def test_atan2_fast_error_below_window_margin():
    rng = np.random.default_rng(0)
    y, x = rng.normal(size=(2, 100000))
    err = np.array([abs(atan2_fast(yy, xx) - math.atan2(yy, xx)) for yy, xx in zip(y[:5000], x[:5000])])
    assert err.max() < 2e-5  # the window margin is 1e-3 rad


def test_far_apart_cells_do_not_interact():
    pos = np.array([[0.0, 0.0], [2.5, 0.0]])
    z = np.zeros((2, 5))
    r = kernel_rates(pos, np.array([0.0, 1.0]), z, z, eta=0.1, v0=0.0)
    assert np.all(r["dpos"] == 0) and np.all(r["dtheta"] == 0)


@pytest.mark.parametrize("N", [16, 144])
def test_rigid_disc_path_equals_exact_lens_force(N):
    """modes = 0: the exact lens force (chord along the line of centres), kernel = twin."""
    pos, theta, a, b, box = dense_config(N, seed=N, M1=0)
    kw = dict(eta=0.1, v0=0.05, box=box)
    assert_same(rates(pos, theta, a, b, **kw), kernel_rates(pos, theta, a, b, **kw))
    d = 1.3
    r = kernel_rates(np.array([[0.0, 0.0], [d, 0.0]]), np.zeros(2), np.zeros((2, 0)), np.zeros((2, 0)), eta=0, v0=0)
    assert r["dpos"][0, 0] == pytest.approx(-2 * math.sqrt(1 - d * d / 4), rel=1e-14)
    assert np.all(r["dtheta"] == 0)


def test_rigid_disc_simulation_runs_and_keeps_theta_diffusing_only():
    from fcsweep.simulation import Simulation

    s = Simulation.from_lattice(64, eta=0.0, v0=0.05, Dr=0.1, seed=2, modes=0)
    s.advance(500)
    assert s.state.a.shape == (64, 0)
    assert np.all(np.isfinite(s.state.pos))


_RATES_SCRIPT = """
import sys
import numpy as np
sys.path.insert(0, {tests!r})
from conftest import dense_config
from fcsweep.kernels.api import kernel_rates
out = []
for quadrature in ("binary", "arc"):
    pos, theta, a, b, box = dense_config(144, seed=3, deform=0.4)
    r = kernel_rates(pos, theta, a, b, eta=0.02, v0=0.03, box=box, contour_points=40, quadrature=quadrature)
    out.append(np.concatenate([r["dpos"].ravel(), r["dtheta"], r["da"].ravel(), r["db"].ravel()]))
np.save(sys.argv[1], np.concatenate(out))
"""


@pytest.mark.slow
def test_fresh_and_cached_kernels_agree_bitwise(tmp_path):
    """Rates from freshly compiled kernels equal, bit for bit, those from kernels loaded
    from numba's disk cache: a run resumed in a new process continues exactly.  (With
    reassociating sums in the rate kernel they differed in the last bit; this needs an
    empty cache, hence two subprocesses, about three minutes.)"""
    import os
    import subprocess
    import sys
    from pathlib import Path

    script = tmp_path / "rates.py"
    script.write_text(_RATES_SCRIPT.format(tests=str(Path(__file__).parent)))
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"))
    for tag in ("fresh", "cached"):
        subprocess.run([sys.executable, str(script), str(tmp_path / f"{tag}.npy")], env=env, check=True)
    fresh = np.load(tmp_path / "fresh.npy")
    cached = np.load(tmp_path / "cached.npy")
    assert np.array_equal(fresh, cached), f"{np.count_nonzero(fresh != cached)} rates differ"
