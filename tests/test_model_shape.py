"""Pure shape math: area, admissibility, projection, lattice (docs/model.md, Cell shape)."""

import math

import numpy as np
import pytest

from fcsweep.model import shape
from fcsweep.model.lattice import hexagonal_lattice, lattice_side


def polygon_area(x, y):
    return 0.5 * np.abs(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


@pytest.mark.parametrize("s", [0.0, 0.2, 0.5, 0.8])
def test_area_is_pi_R0_squared_for_any_admissible_shape(s):
    rng = np.random.default_rng(1)
    c = rng.normal(size=5) + 1j * rng.normal(size=5)
    c *= s / np.abs(c).sum()
    phi = np.linspace(0, 2 * np.pi, 20000, endpoint=False)
    R, _ = shape.radius(phi, c.real, c.imag, R0=1.3)
    area = polygon_area(R * np.cos(phi), R * np.sin(phi))
    # polygon with 2e4 vertices: relative error ~ (2 pi / 2e4)^2 / 6 ~ 2e-8
    assert area == pytest.approx(math.pi * 1.3**2, rel=1e-7)


def test_circle_shape_index_and_bounds():
    a = np.zeros((3, 5))
    assert np.allclose(shape.shape_index(a, a), shape.Q_CIRCLE, atol=1e-12)
    assert np.allclose(shape.bounding_radius(a, a), 1.0)
    assert np.all(shape.is_admissible(a, a))


def test_admissible_shapes_have_positive_radius_and_bounds_hold():
    rng = np.random.default_rng(2)
    phi = np.linspace(0, 2 * np.pi, 4096, endpoint=False)
    for _ in range(200):
        c = rng.normal(size=5) + 1j * rng.normal(size=5)
        c *= rng.uniform(0.0, 0.999) * shape.ADMISSIBLE_BOUND / np.abs(c).sum()
        R, _ = shape.radius(phi, c.real, c.imag)
        assert R.min() > 0
        assert R.max() <= shape.bounding_radius(c.real, c.imag) + 1e-12
        assert R.min() >= shape.inner_radius(c.real, c.imag) - 1e-12


def test_projection_scales_back_to_margin_and_counts():
    a = np.array([[0.6, 0.36, 0, 0, 0], [0.01, 0, 0, 0, 0]])
    b = np.zeros_like(a)
    a2, b2, hit = shape.project_admissible(a, b)
    assert hit.tolist() == [True, False]
    assert shape.amplitude_sum(a2, b2)[0] == pytest.approx(shape.PROJECTION_MARGIN * shape.ADMISSIBLE_BOUND)
    assert np.array_equal(a2[1], a[1])
    # direction of the mode vector is kept
    assert a2[0, 1] / a2[0, 0] == pytest.approx(0.36 / 0.6)


def test_perimeter_gradient_matches_finite_differences():
    rng = np.random.default_rng(3)
    c = rng.normal(size=5) + 1j * rng.normal(size=5)
    c *= 0.4 / np.abs(c).sum()
    a, b = c.real.copy(), c.imag.copy()
    ga, gb = shape.perimeter_gradient(a, b, points=2048)
    h = 1e-6
    for n in range(5):
        e = np.zeros(5)
        e[n] = h
        fd_a = (shape.perimeter(a + e, b, points=4096) - shape.perimeter(a - e, b, points=4096)) / (2 * h)
        fd_b = (shape.perimeter(a, b + e, points=4096) - shape.perimeter(a, b - e, points=4096)) / (2 * h)
        assert ga[0, n] == pytest.approx(fd_a, abs=1e-7)
        assert gb[0, n] == pytest.approx(fd_b, abs=1e-7)


@pytest.mark.parametrize("N,n", [(4, 2), (16, 4), (1024, 32), (4900, 70), (10000, 100)])
def test_lattice_side_accepts_even_squares(N, n):
    assert lattice_side(N) == n


@pytest.mark.parametrize("N,near", [(1000, "900 (n=30) and 1024 (n=32)"), (49, "36 (n=6) and 64 (n=8)"),
                                    (50, "36 (n=6) and 64 (n=8)")])
def test_lattice_side_rejects_others_naming_nearest(N, near):
    with pytest.raises(ValueError, match=r"n\*n with n even") as e:
        lattice_side(N)
    assert near in str(e.value)


def test_lattice_density_and_spacing():
    pos, box = hexagonal_lattice(64, 0.95)
    assert 64 * math.pi / (box[0] * box[1]) == pytest.approx(0.95, rel=1e-12)
    assert box[0] / box[1] == pytest.approx(2 / math.sqrt(3))
    d = pos[:, None] - pos[None]
    d -= box * np.rint(d / box)
    r = np.hypot(d[..., 0], d[..., 1])
    np.fill_diagonal(r, np.inf)
    a = math.sqrt(2 * math.pi / (0.95 * math.sqrt(3)))
    assert np.allclose(r.min(axis=1), a)
    assert np.all(np.sum(np.isclose(r, a), axis=1) == 6)


@pytest.mark.parametrize("n", [2, 4, 6])
@pytest.mark.parametrize("R0,mu_shape", [(1.0, 1.0), (2.0, 0.5)])
def test_tension_rate_is_the_linear_relaxation_rate_of_the_model(n, R0, mu_shape):
    """An isolated, slightly deformed cell: -da_n/dt / a_n from the rates of the model
    equals pi mu_shape eta R0 (n^2 - 1) to second order in a_n (here 1e-5)."""
    from fcsweep.model.rates import rates
    from fcsweep.model.shape import tension_rate

    a = np.zeros((1, 5))
    a[0, n - 2] = 1e-5
    r = rates(np.zeros((1, 2)), np.zeros(1), a, np.zeros((1, 5)), eta=0.7, v0=0.0, R0=R0, mu_shape=mu_shape)
    assert -r["da"][0, n - 2] / 1e-5 == pytest.approx(tension_rate(n, 0.7, mu_shape, R0), rel=1e-6)


def test_euler_tension_relaxation_is_stable_only_below_twice_the_rate():
    """Explicit Euler on the isolated cell's mode 6 (amplification 1 - dt lambda_6 per
    step): no sign flip at dt = 1/lambda, flips but at least halves per step at
    max_stable_dt = 1.5/lambda, grows at 2.2/lambda."""
    from fcsweep.model.rates import rates
    from fcsweep.model.shape import max_stable_dt, tension_rate

    eta = 1.0
    lam = tension_rate(6, eta)

    def amplitudes(dt, steps):
        a = np.zeros((1, 5))
        a[0, 4] = 0.01
        out = []
        for _ in range(steps):
            a = a + dt * rates(np.zeros((1, 2)), np.zeros(1), a, np.zeros((1, 5)), eta=eta, v0=0.0)["da"]
            out.append(a[0, 4])
        return np.array(out)

    at = amplitudes(1.0 / lam, 5)
    assert np.all(at > -1e-12) and abs(at[-1]) < 1e-6  # one step removes the linear part
    assert max_stable_dt(eta, 6) == pytest.approx(1.5 / lam)
    flips = amplitudes(max_stable_dt(eta, 6), 8)
    assert np.any(flips < 0) and np.all(np.abs(flips[1:]) <= 0.51 * np.abs(flips[:-1]))
    grows = amplitudes(2.2 * max_stable_dt(eta, 6) / 1.5, 10)
    assert abs(grows[-1]) > 0.01


@pytest.mark.parametrize("eta", [0.01, 0.03, 0.0731, 0.1, 1.0, 2.99])
@pytest.mark.parametrize("modes", [2, 6, 13, 32])
def test_quoted_dt_bound_is_accepted_and_just_above_is_refused(eta, modes):
    """The message quotes the allowed bound rounded down, so a user can paste it."""
    from fcsweep.model.shape import dt_problem, max_stable_dt

    limit = max_stable_dt(eta, modes)
    msg = dt_problem(1.01 * limit, eta, modes)
    quoted = float(msg.split("dt <= ")[1].split()[0])
    assert 0.99 * limit <= quoted <= limit
    assert dt_problem(quoted, eta, modes) == ""
