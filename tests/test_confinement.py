"""Confinement (docs/model.md, "Confinement"): the wall's reference rates against finite
differences of its energy, the numba kernel against the reference, the force a cell pressed
against a wall feels, cells kept inside a packed well, resume, and the validation."""

import math

import numpy as np
import pytest

from fcsweep.config import ConfigError, load_config
from fcsweep.config.limits import check_runnable
from fcsweep.kernels.api import kernel_rates, param_vector
from fcsweep.kernels.records import P_WALL
from fcsweep.model.confinement import (cell_contours, confinement_of, confinement_of_params, wall_forces, wall_gap,
                                       wall_overlap_area, wall_pressure, wall_rates, wall_weights)
from fcsweep.model.rates import radial_gap
from fcsweep.simulation import Simulation

KEYS = ("dpos", "dtheta", "da", "db")


def _cells_at_wall(conf, rng, n=4, M1=5, depth=0.3):
    """n cells whose centres lie 1 - depth R0 inside the wall, random shapes and angles."""
    th = rng.uniform(0, 2 * np.pi, n)
    a = rng.normal(0, 0.05, (n, M1))
    b = rng.normal(0, 0.05, (n, M1))
    if conf.kind == "well":
        ang = rng.uniform(0, 2 * np.pi, n)
        pos = conf.centre + (conf.size - 1.0 + depth) * np.stack([np.cos(ang), np.sin(ang)], axis=1)
    else:
        side = rng.integers(0, 2, n)
        y = np.where(side == 0, conf.y_lo + 1.0 - depth, conf.y_hi - 1.0 + depth)
        pos = np.stack([rng.uniform(0, conf.host[0], n), y], axis=1)
    return pos, th, a, b


@pytest.mark.parametrize("kind", ["well", "channel"])
@pytest.mark.parametrize("M1", [0, 5])
def test_reference_wall_rates_are_minus_the_wall_energy_gradient(kind, M1):
    """Central differences (step 1e-4) of the area beyond the wall, integrated on 20 000
    angles, give the reference's rates at K = 2000 (linear rule: error O(1/K^2) ~ 1e-5 of the
    O(1) rates; the energy's quadrature error is smooth in the state and cancels in the
    difference)."""
    rng = np.random.default_rng(7)
    conf = confinement_of(kind, 7.0, 16, 0.9)
    pos, th, a, b = _cells_at_wall(conf, rng, 3, M1)
    r = wall_rates(pos, th, a, b, conf, contour_points=2000, quadrature="linear", mu_theta=1.3, mu_shape=0.7)
    h = 1e-4

    def energy(p=pos, t=th, aa=a, bb=b):
        return wall_overlap_area(p, t, aa, bb, conf, points=20000)

    assert (energy() > 0.01).all()  # every cell reaches beyond the wall
    for i in range(3):
        for c in range(2):
            dp = np.zeros_like(pos)
            dp[i, c] = h
            fd = (energy(p=pos + dp)[i] - energy(p=pos - dp)[i]) / (2 * h)
            assert r["dpos"][i, c] == pytest.approx(-fd, abs=1e-3)
        if M1:
            dt = np.zeros(3)
            dt[i] = h
            fd = (energy(t=th + dt)[i] - energy(t=th - dt)[i]) / (2 * h)
            assert r["dtheta"][i] == pytest.approx(-1.3 * fd, abs=1e-3)
            for m in (0, 3):
                da = np.zeros_like(a)
                da[i, m] = h
                fd = (energy(aa=a + da)[i] - energy(aa=a - da)[i]) / (2 * h)
                assert r["da"][i, m] == pytest.approx(-0.7 * fd, abs=1e-3)
                fd = (energy(bb=b + da)[i] - energy(bb=b - da)[i]) / (2 * h)
                assert r["db"][i, m] == pytest.approx(-0.7 * fd, abs=1e-3)


@pytest.mark.parametrize("kind", ["well", "channel"])
@pytest.mark.parametrize("quadrature,M1", [("binary", 5), ("linear", 5), ("arc", 5), ("arc", 7), ("binary", 0)])
def test_kernel_wall_rates_match_the_reference(kind, quadrature, M1):
    """Kernel rates with the wall minus those without equal the reference's wall rates to
    round-off (1e-12 of O(1) rates), cells near and far from the wall, per-cell radii too."""
    rng = np.random.default_rng(3)
    conf = confinement_of(kind, 0.0, 16, 0.9)
    pos, th, a, b = _cells_at_wall(conf, rng, 5, M1)
    pos = np.vstack([pos, conf.centre + [0.3, -0.2]])  # one cell far from the wall
    th, a, b = np.append(th, 0.4), np.vstack([a, np.zeros((1, M1))]), np.vstack([b, np.zeros((1, M1))])
    for radii in (None, np.array([1.0, 0.9, 1.1, 0.95, 1.05, 1.0])):
        ref = wall_rates(pos, th, a, b, conf, quadrature=quadrature, radii=radii)
        kw = dict(eta=0.1, v0=0.02, quadrature=quadrature, radii=radii)
        on = kernel_rates(pos, th, a, b, wall=conf, **kw)
        off = kernel_rates(pos, th, a, b, box=conf.host, **kw)
        for k in KEYS:
            np.testing.assert_allclose(on[k] - off[k], ref[k], rtol=0, atol=1e-12)
        assert np.abs(ref["dpos"][:5]).max() > 0.1 and np.all(ref["dpos"][5] == 0)


def test_disc_pressed_against_a_wall_feels_the_chord():
    """A disc whose centre lies d < R0 inside a straight wall feels the chord 2 sqrt(R0^2 - d^2)
    of its part beyond it, normal to the wall, pointing in (rigid discs: exactly; a circular
    contour: converging with K, error at K = 40 below 2 % for the linear rule, 1.1 % at the
    shallowest contact d = 0.95); in a well, the
    chord of the two circles."""
    conf = confinement_of("channel", 10.0, 16, 0.5)
    for d in (0.2, 0.6, 0.95):
        pos = np.array([[3.0, conf.y_lo + d]])
        exact = 2.0 * math.sqrt(1.0 - d * d)
        disc = wall_forces(pos, [0.3], np.zeros((1, 0)), np.zeros((1, 0)), conf)[0]
        assert disc == pytest.approx([0.0, exact], abs=1e-14)
        errs = []
        for K in (40, 160, 640):
            f = kernel_rates(pos, [0.3], np.zeros((1, 5)), np.zeros((1, 5)), eta=0.0, v0=0.0, wall=conf,
                             contour_points=K, quadrature="linear")["dpos"][0]
            errs.append(math.hypot(f[0], f[1] - exact) / exact)
        assert errs[0] < 2e-2 and errs[2] < errs[0] / 30  # measured 0.1-1.1 % at K = 40, ~1/K^2
    well = confinement_of("well", 5.0, 16, 0.5)
    pos = well.centre + [[4.5, 0.0]]
    f = wall_forces(pos, [0.0], np.zeros((1, 0)), np.zeros((1, 0)), well)[0]
    x = (4.5 ** 2 + 25.0 - 1.0) / (2 * 4.5)  # the chord's distance from the well's centre
    assert f == pytest.approx([-2.0 * math.sqrt(25.0 - x * x), 0.0], abs=1e-14)


def test_a_cell_driven_into_a_wall_stops_where_the_wall_force_balances_v0():
    """Cells self-propelled straight into the lower wall (D_r = 0, polarity held) come to
    rest flattened against it: the wall's force on each equals v0 (mobility 1) to 1e-3, and
    they reach no deeper than a rigid disc under the same force, R0 - sqrt(R0^2 - (v0/2)^2).
    (dt = 0.001: at the paper's 0.005 an isolated contact chatters under Euler, the force's
    standard deviation about its mean, which stays v0; shapes relax with an oscillation that
    has decayed to 1e-4 after 50 time units.)"""
    v0 = 0.05
    sim = Simulation.create(4, seed=1, eta=0.1, v0=v0, Dr=0.0, mu_theta=0.0, dt=0.001, boundary="channel",
                            boundary_size=12.0, density=0.05, initial="disordered")
    s, conf = sim.state, sim.confinement
    s.theta[:] = -0.5 * math.pi
    s.pos[:, 1] = conf.y_lo + 1.1
    sim.advance(60000)
    F = wall_forces(s.pos, s.theta, s.a, s.b, conf)
    np.testing.assert_allclose(F[:, 1], v0, rtol=1e-3)
    x, _, _ = cell_contours(s.pos, s.theta, s.a, s.b)
    depth = wall_gap(x, conf).max(axis=1)
    assert (depth > 0).all() and (depth < 1.0 - math.sqrt(1.0 - (v0 / 2) ** 2)).all()
    assert np.abs(sim.rates()["dpos"][:, 1]).max() < 1e-4  # at rest
    assert np.abs(s.a).max() > 0.01  # flattened against the wall


@pytest.fixture(scope="module")
def packed_well():
    """64 cells at area fraction 0.9 in a well, v0 = 0.05, 1000 steps past the start."""
    sim = Simulation.create(64, seed=5, eta=0.05, v0=0.05, Dr=0.1, boundary="well", density=0.9,
                            initial="disordered")
    sim.advance(1000)
    return sim


def test_no_cell_leaves_a_packed_well(packed_well):
    """In a packed, active well every centre stays more than R0 / 2 inside, and the wall is
    entered as a neighbour is: no contour point lies beyond it deeper than 0.05 R0 nor deeper
    than twice the deepest point of any cell inside another in the same state (measured over
    three states: wall 0.013-0.028 R0, cells 0.026-0.049 R0)."""
    sim = packed_well
    s, conf = sim.state, sim.confinement
    assert (wall_gap(s.pos, conf) < -0.5).all()
    x, _, _ = cell_contours(s.pos, s.theta, s.a, s.b)
    depth = wall_gap(x, conf).max(axis=1)
    cells = max(radial_gap(x[i], s.pos[j], s.theta[j], s.a[j], s.b[j]).max()
                for i in range(len(x)) for j in range(len(x))
                if i != j and np.linalg.norm(s.pos[i] - s.pos[j]) < 3.7)
    assert 0 < depth.max() < min(0.05, 2.0 * cells)
    assert (depth > 0).sum() >= 8  # the wall is pressed on
    assert wall_pressure(s.pos, s.theta, s.a, s.b, conf) > 0
    assert (s.image == 0).all()  # nothing crossed the host box


def test_a_confined_run_resumes_bit_for_bit(packed_well):
    """A chunked run with a checkpoint in the middle is the uninterrupted run, bit for bit."""
    kw = dict(seed=9, eta=0.05, v0=0.05, Dr=0.1, boundary="channel", boundary_size=6.0, density=0.85,
              initial="disordered")
    one = Simulation.create(16, **kw)
    one.advance(300)
    two = Simulation.create(16, **kw)
    two.advance(150)
    two = Simulation.from_checkpoint(two.to_checkpoint())
    two.advance(150)
    for name in ("pos", "image", "theta", "a", "b"):
        assert np.array_equal(getattr(one.state, name), getattr(two.state, name))


def test_channel_is_periodic_along_x_only():
    """Cells driven along x cross the host box's x edge (image counters change) and never
    its y edge; all stay between the walls."""
    sim = Simulation.create(16, seed=2, eta=0.1, v0=0.1, Dr=0.01, mu_theta=0.0, boundary="channel",
                            boundary_size=6.0, density=0.7, initial="disordered")
    sim.state.theta[:] = 0.0
    sim.advance(2000)
    s, conf = sim.state, sim.confinement
    assert (s.image[:, 0] != 0).any() and (s.image[:, 1] == 0).all()
    assert (wall_gap(s.pos, conf) < 0).all()


def test_geometry_follows_n_and_density():
    """Well: pi R_w^2 = N pi R0^2 / density (or R_w = boundary_size R0, area fraction N/bs^2);
    channel: W L_x = N pi R0^2 / density; the host box leaves the margin on walled sides."""
    w = confinement_of("well", 0.0, 64, 0.8)
    assert w.area_fraction == pytest.approx(0.8) and w.size == pytest.approx(math.sqrt(64 / 0.8))
    assert confinement_of("well", 10.0, 64, 0.8).area_fraction == pytest.approx(0.64)
    c = confinement_of("channel", 5.0, 64, 0.8)
    assert c.size == 5.0 and c.area_fraction == pytest.approx(0.8) and c.host[1] > c.size + 2 * 3.9
    assert c.wall_length == pytest.approx(2 * c.host[0])
    assert confinement_of_params({"N": 64}) is None
    same = confinement_of_params({"N": 64, "boundary": "well", "density": 0.8})
    assert same.size == pytest.approx(w.size)


def test_binary_and_linear_wall_weights():
    """binary: 1 beyond the wall; linear: the fraction of each point's arc with the gap,
    linear from -1 to 3, positive: the crossing a quarter of the way along the segment leaves a
    quarter of the outer point's arc beyond the wall and all of the inner one's."""
    g = np.array([-1.0, 3.0, 3.0, -1.0])
    assert np.array_equal(wall_weights(g, "binary"), [0, 1, 1, 0])
    np.testing.assert_allclose(wall_weights(g, "linear"), [0.25, 1.0, 1.0, 0.25])


def test_periodic_runs_have_no_wall_term():
    """At the default boundary the parameter vector's wall code is 0 (the kernels skip the
    wall) and the box is the lattice's."""
    sim = Simulation.create(16, seed=1, eta=0.1, v0=0.01)
    assert sim.confinement is None and sim._prm[P_WALL] == 0.0
    assert param_vector(box=(1, 1), R0=1, eta=0, v0=0, mu_theta=1, mu_shape=1)[P_WALL] == 0.0


@pytest.mark.parametrize("model,key,words", [
    ({"boundary": "well"}, "model.boundary", "needs initial: disordered"),
    ({"boundary": "well", "initial": "disordered", "integrator": "contact-implicit"}, "model.boundary",
     "needs integrator 'euler'"),
    ({"boundary": "channel", "initial": "disordered", "boundary_size": 1.0}, "model.boundary_size", "too small"),
    ({"boundary": "well", "initial": "disordered", "boundary_size": 5.0}, "model.boundary_size",
     "cannot hold N = 64"),
    ({"boundary_size": 5.0}, "model.boundary_size", "needs boundary 'well' or 'channel'"),
])
def test_bad_confinement_is_refused_before_anything_runs(tmp_path, model, key, words):
    """The config check names the key and says why; SimParams refuses the same."""
    text = ("output: out\nseed: 1\ngrid: {v0: [0.02]}\nmodel: {N: 64, eta: 0.1, "
            + ", ".join(f"{k}: {v}" for k, v in model.items()) + "}\nrun: {steps: 100, sample_every: 50}\n")
    path = tmp_path / "c.yaml"
    path.write_text(text)
    with pytest.raises(ConfigError) as err:
        check_runnable(load_config(path))
    assert key in str(err.value) and words in str(err.value)
    with pytest.raises(ValueError, match=words.split(":")[0].split(" =")[0]):
        Simulation.create(64, seed=1, eta=0.1, v0=0.02, **model)
