"""Cell size differences: per-cell radii R0,i (``size_distribution`` and its parameters).

The draw (own stream, mean R0), the kernels against their numpy twin with radii, two
cells of different sizes (areas kept, the contact the energy predicts), a bidisperse
disordered start, checkpoints and trajectories that carry the radii, the radical
tessellation, and the monodisperse default left bit for bit as it was.
"""

import math

import numpy as np
import pytest

from conftest import dense_config
from fcsweep.kernels.api import kernel_rates
from fcsweep.model.discs import lens_chord
from fcsweep.model.rates import rates
from fcsweep.model.sizes import cell_radii, radius_bounds

KEYS = ("dpos", "dtheta", "da", "db")


def _assert_same(r1, r2, tol=1e-11):
    for k in KEYS:
        if r1[k].size:
            scale = max(1.0, np.abs(r1[k]).max())
            assert np.abs(r1[k] - r2[k]).max() <= tol * scale, k


@pytest.mark.parametrize("dist", ["bidisperse", "lognormal", "gaussian"])
def test_radii_have_mean_R0_stay_in_bounds_and_are_reproducible(dist):
    r = cell_radii(1000, 7, dist, 1.4, 0.3, 0.2, R0=1.5)
    assert r.shape == (1000,) and r.mean() == pytest.approx(1.5, rel=1e-14)
    lo, hi = radius_bounds(dist, 1.4, 0.3, 0.2, R0=1.5)
    assert lo * (1 - 1e-12) <= r.min() and r.max() <= hi * (1 + 1e-12)
    assert np.array_equal(r, cell_radii(1000, 7, dist, 1.4, 0.3, 0.2, R0=1.5))
    assert not np.array_equal(r, cell_radii(1000, 8, dist, 1.4, 0.3, 0.2, R0=1.5))
    if dist == "bidisperse":
        small = r < r.mean()
        assert small.sum() == 300 and r[~small].min() / r[small].max() == pytest.approx(1.4)
    else:
        assert r.std() / r.mean() == pytest.approx(0.2, rel=0.25)  # truncation at 2 widths narrows it
    assert cell_radii(1000, 7, "monodisperse") is None


@pytest.mark.parametrize("quadrature", ["binary", "arc"])
@pytest.mark.parametrize("N", [16, 64])
def test_kernel_equals_twin_with_radii(quadrature, N):
    """Per-cell radii in every rule: the kernel reads them from geo[:, 5], the twin takes
    them per cell; all-image path (N = 16) and neighbour list (N = 64), to round-off."""
    pos, theta, a, b, box = dense_config(N, seed=N + 1, deform=0.1, density=0.85)
    radii = cell_radii(N, 3, "bidisperse", 1.3, 0.5)
    kw = dict(eta=0.05, v0=0.03, box=box, contour_points=40, quadrature=quadrature, radii=radii)
    _assert_same(rates(pos, theta, a, b, **kw), kernel_rates(pos, theta, a, b, **kw))
    plain = kernel_rates(pos, theta, a, b, **{**kw, "radii": None})
    assert np.abs(plain["dpos"] - kernel_rates(pos, theta, a, b, **kw)["dpos"]).max() > 1e-3


def test_rigid_discs_of_two_sizes_push_with_their_lens_chord():
    z = np.zeros((2, 0))
    for d in (1.3, 1.8, 2.1):
        r = kernel_rates(np.array([[0.0, 0.0], [d, 0.0]]), np.zeros(2), z, z, eta=0, v0=0, radii=[0.9, 1.3])
        assert r["dpos"][0, 0] == pytest.approx(-lens_chord(d, 0.9, 1.3), rel=1e-13)
        assert r["dpos"][1, 0] == pytest.approx(lens_chord(d, 0.9, 1.3), rel=1e-13)


def _two_cells_from(pos, theta, a, b, radii, steps, eta, v0, dt=0.01):
    """Integrate two free cells (open boundaries) with the kernels' rates by explicit
    Euler (no noise)."""
    for _ in range(steps):
        r = kernel_rates(pos, theta, a, b, eta=eta, v0=v0, radii=radii, quadrature="arc")
        pos = pos + dt * r["dpos"]
        theta = theta + dt * r["dtheta"]
        a = a + dt * r["da"]
        b = b + dt * r["db"]
    return pos, theta, a, b


def _two_cells(modes, radii, d, eta=0.5, v0=0.05):
    """Two circles at distance d facing each other after 3000 steps of 0.01: v0 pushes
    them together, the overlap apart."""
    M1 = max(modes - 1, 0)
    return _two_cells_from(np.array([[0.0, 0.0], [d, 0.0]]), np.array([0.0, math.pi]), np.zeros((2, M1)),
                           np.zeros((2, M1)), radii, 3000, eta, v0)


def test_two_cells_of_different_size_reach_the_contact_the_energy_predicts():
    """Rigid discs of radii 0.8 and 1.2 pushed together at v0 stop where the lens chord
    (minus dA/dd) equals v0: d* from 2 sqrt(R1^2 - x^2) = v0, x = (d^2 + R1^2 - R2^2)/(2d)."""
    R1, R2, v0 = 0.8, 1.2, 0.05
    pos, *_ = _two_cells(0, [R1, R2], 1.9, v0=v0)
    d = pos[1, 0] - pos[0, 0]
    assert lens_chord(d, R1, R2) == pytest.approx(v0, rel=1e-6)
    lo, hi = 1.5, R1 + R2
    for _ in range(80):  # the predicted distance by bisection
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if lens_chord(mid, R1, R2) > v0 else (lo, mid)
    assert d == pytest.approx(lo, abs=1e-6)


def test_deformable_cells_of_different_size_keep_their_areas_and_balance_forces():
    """Contour cells (M = 6, arc rule) of radii 0.8 and 1.2 pressed together at v0: each
    keeps the area pi R0,i^2 of its own radius (the rectangle rule on 4096 points is exact
    for these trigonometric polynomials), the pair settles at a flattened contact where
    the overlap force balances v0 on average (explicit Euler makes such a flat contact
    chatter from step to step, so the balance is over 1000 steps: the mean velocity is
    the drift of the centres), with the centres closer than those of rigid discs of the
    same radii under the same push (both balance v0 with a chord of v0; the flattened
    contours meet along it nearer the centres)."""
    from fcsweep.model.shape import radius

    R = np.array([0.8, 1.2])
    pos, theta, a, b = _two_cells(6, R, 1.95, eta=0.2, v0=0.05)
    phi = np.linspace(0, 2 * np.pi, 4096, endpoint=False)
    for i in range(2):
        r, _ = radius(phi, a[i], b[i], R[i])
        area = 0.5 * np.sum(r * r) * (phi[1] - phi[0])
        assert area == pytest.approx(np.pi * R[i] ** 2, rel=1e-9)
    later, *_ = _two_cells_from(pos, theta, a, b, R, steps=1000, eta=0.2, v0=0.05)
    drift = (later - pos)[:, 0] / (1000 * 0.01)
    assert np.abs(drift).max() < 0.05 * 0.05  # mean force balance to 5 % of v0
    d = pos[1, 0] - pos[0, 0]
    disc = _two_cells(0, R, 1.95, v0=0.05)[0]
    assert 1.5 < d < disc[1, 0] - disc[0, 0] < R.sum()
    assert (a[:, 0] < -1e-3).all()  # both flattened along the line of centres (mode 2)


def test_bidisperse_disordered_start_runs_and_stays_admissible():
    from fcsweep.model.shape import ADMISSIBLE_BOUND, amplitude_sum
    from fcsweep.simulation import Simulation

    sim = Simulation.create(64, seed=4, eta=0.05, v0=0.03, initial="disordered", size_distribution="bidisperse",
                            quadrature="binary")
    r = sim.radii
    assert r is not None and np.unique(np.round(r, 12)).size == 2
    box = sim.state.box
    assert np.sum(np.pi * r * r) / (box[0] * box[1]) == pytest.approx(0.95, rel=1e-12)
    sim.advance(400)
    s = sim.state
    assert np.isfinite(s.pos).all() and np.isfinite(s.a).all()
    assert amplitude_sum(s.a, s.b).max() < ADMISSIBLE_BOUND
    assert s.projections <= 0.01 * 64 * 400
    # checkpoints carry the radii and resume bit for bit
    ck = sim.to_checkpoint()
    assert np.array_equal(ck["radii"], r)
    again = Simulation.from_checkpoint(ck)
    sim.advance(50)
    again.advance(50)
    assert np.array_equal(sim.state.pos, again.state.pos) and np.array_equal(sim.state.a, again.state.a)


def test_monodisperse_default_is_bit_identical_and_keeps_run_ids():
    from fcsweep.config.settings import run_id_of
    from fcsweep.model.parameters import DEFAULTS
    from fcsweep.simulation import Simulation

    runs = []
    for extra in ({}, {"size_distribution": "monodisperse", "size_ratio": 1.4, "size_fraction": 0.5,
                       "size_width": 0.1}):
        sim = Simulation.create(16, seed=9, eta=0.05, v0=0.05, quadrature="binary", initial="disordered", **extra)
        sim.advance(30)
        runs.append(sim)
    assert runs[0].radii is None
    for name in ("pos", "theta", "a", "b", "image"):
        assert np.array_equal(getattr(runs[0].state, name), getattr(runs[1].state, name))
    assert "radii" not in runs[0].to_checkpoint()
    params = {**{k: v for k, v in DEFAULTS.items() if v is not None}, "N": 64, "eta": 0.05, "v0": 0.03}
    old = {k: v for k, v in params.items() if not k.startswith("size_") and k != "core_exponent"}
    assert run_id_of(params, 0) == run_id_of(old, 0)
    assert run_id_of({**params, "size_distribution": "bidisperse"}, 0) != run_id_of(old, 0)


def test_trajectory_stores_radii_only_when_sizes_differ(tmp_path):
    from fcsweep.io.h5md import create_trajectory, verify_trajectory
    from fcsweep.io.trajectory import open_trajectory

    for radii in (None, np.array([0.8, 1.2, 0.8, 1.2])):
        path = tmp_path / f"t{radii is None}.h5"
        create_trajectory(path, n_cells=4, box=[4.0, 4.0], modes_width=5, fields=("position", "image"),
                          parameters={"N": 4, "complete": 1}, dt=0.01, radii=radii)
        t = open_trajectory(path)
        assert t.fields == ("image", "position") or set(t.fields) == {"image", "position"}
        assert (t.radii is None) if radii is None else np.array_equal(t.radii, radii)
        assert verify_trajectory(path) is None


def test_radical_tessellation_equals_voronoi_for_equal_radii():
    from fcsweep.analysis.voronoi import voronoi_neighbors
    from fcsweep.model.lattice import hexagonal_lattice

    rng = np.random.default_rng(1)
    pos, box = hexagonal_lattice(144, 0.95)
    pos = np.mod(pos + rng.normal(0, 0.3, pos.shape), box)
    a = voronoi_neighbors(pos, box)
    b = voronoi_neighbors(pos, box, np.full(144, 1.0))
    assert set(zip(a.i.tolist(), a.j.tolist())) == set(zip(b.i.tolist(), b.j.tolist()))
    # unequal radii move the edges: a large cell gains neighbours, and Euler's 6 holds
    r = cell_radii(144, 2, "bidisperse", 1.4, 0.5)
    c = voronoi_neighbors(pos, box, r)
    assert c.n_sides.mean() == pytest.approx(6.0)
    assert c.n_sides[r > 1].mean() > c.n_sides[r < 1].mean()


def test_config_refuses_sizes_on_the_lattice(tmp_path):
    import yaml

    from fcsweep.config import ConfigError, check_runnable, parse_config

    def cfg(model):
        return parse_config(yaml.safe_dump({"output": str(tmp_path / "o"), "seed": 1, "grid": {"v0": [0.03]},
                                            "model": {"N": 16, "eta": 0.05, **model},
                                            "run": {"steps": 10, "sample_every": 5}}))

    with pytest.raises(ConfigError, match="size_distribution.*initial: disordered"):
        check_runnable(cfg({"size_distribution": "bidisperse"}))
    with pytest.raises(ConfigError, match="size_ratio"):
        cfg({"size_distribution": "bidisperse", "size_ratio": 5.0})
    with pytest.raises(ConfigError, match="size_distribution"):
        cfg({"size_distribution": "polydisperse"})
    check_runnable(cfg({"size_distribution": "bidisperse", "initial": "disordered"}))
    with pytest.raises(ConfigError, match="size_distribution.*adhesion"):  # the adhesion term has one R0
        check_runnable(cfg({"size_distribution": "bidisperse", "initial": "disordered", "adhesion": 0.1}))


@pytest.mark.parametrize("modes", [0, 6])
def test_unequal_circles_with_a_harder_core(modes):
    """Both extensions at once: circles of radii 0.9 and 1.3 under the energy A^2 push
    with 2 A chord, A and chord those of their lens (rigid discs exact; contour cells
    through the arc rule's area, whose Gauss sums are exact for circles)."""
    from fcsweep.model.discs import lens_area

    M1 = max(modes - 1, 0)
    z = np.zeros((2, M1))
    for d in (1.4, 1.9, 2.1):
        r = kernel_rates(np.array([[0.0, 0.0], [d, 0.0]]), np.zeros(2), z, z, eta=0.0, v0=0.0, radii=[0.9, 1.3],
                         core_exponent=2.0)
        expect = 2.0 * lens_area(d, 0.9, 1.3) * lens_chord(d, 0.9, 1.3)
        assert r["dpos"][0, 0] == pytest.approx(-expect, rel=1e-12 if modes == 0 else 1e-6)
