"""Tests of the exact overlap-area / energy / rates reference (fcsweep.model.overlap_exact)."""

from __future__ import annotations

import importlib.util
import pathlib
import time

import numpy as np
import pytest

from fcsweep.model.overlap_exact import (
    continuum_rates,
    exact_energy,
    inside_arcs,
    overlap_area,
    reference_rates,
)
from fcsweep.model.shape import ADMISSIBLE_BOUND, amplitude_sum, perimeter_gradient, radius

# benchmarks/ is not a package on the path under plain `pytest`: load it by file
_spec = importlib.util.spec_from_file_location(
    "fcsweep_bench_snapshots", pathlib.Path(__file__).resolve().parents[1] / "benchmarks" / "snapshots.py")
_snapshots = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_snapshots)
dense_snapshot = _snapshots.dense_snapshot
snapshot_from_arrays = _snapshots.snapshot_from_arrays

Z = np.zeros(5)


def lens(d, R=1.0):
    """Area of the lens of two circles of radius R at centre distance d."""
    if d >= 2 * R:
        return 0.0
    return 2 * R * R * np.arccos(d / (2 * R)) - 0.5 * d * np.sqrt(4 * R * R - d * d)


def random_cell(rng, s, m=5):
    amp = rng.exponential(size=m)
    ph = rng.uniform(0, 2 * np.pi, m)
    amp *= s / amp.sum()
    return amp * np.cos(ph), amp * np.sin(ph)


def rotate(v, alpha):
    c, s = np.cos(alpha), np.sin(alpha)
    return v @ np.array([[c, s], [-s, c]])


# ----------------------------------------------------------------------------- areas
@pytest.mark.parametrize("d", [0.0, 0.1, 0.7, 1.3, 1.9, 1.999, 2.0 - 1e-6, 2.05])
def test_two_circles_lens_area(d):
    # closed-form arcs: the only error is round-off (~1e-15 on areas of order 1)
    A = overlap_area([0.0, 0.0], 0.3, Z, Z, [d * np.cos(0.4), d * np.sin(0.4)], -1.1, Z, Z)
    assert A == pytest.approx(lens(d), abs=1e-13)


def test_shallow_contact_between_samples_is_found():
    # chord 2*sqrt(1 - (1 - 5e-7)^2) ~ 2e-3 << sample spacing 2*pi/256 ~ 0.025: found by
    # the near-zero-extremum refinement, not by a sign change of the samples
    d = 2.0 - 1e-6
    A = overlap_area([0, 0], 0.0, Z, Z, [d, 0], 0.5, Z, Z, resolution=256)
    assert lens(d) > 0
    assert A == pytest.approx(lens(d), rel=1e-9)


def test_scaled_circles_R0():
    R0, d = 2.5, 3.1
    A = overlap_area([0, 0], 0.0, Z, Z, [d, 0], 0.0, Z, Z, R0=R0)
    assert A == pytest.approx(lens(d, R0), abs=1e-12)


def test_deformed_pair_against_pixel_count():
    rng = np.random.default_rng(5)
    a1, b1 = random_cell(rng, 0.4)
    a2, b2 = random_cell(rng, 0.4)
    ri, rj, ti, tj = np.array([0.1, -0.2]), np.array([1.2, 0.5]), 0.7, -2.0
    A = overlap_area(ri, ti, a1, b1, rj, tj, a2, b2)
    n = 1000
    xs = np.linspace(-2, 3, n, endpoint=False) + 2.5 / n
    ys = np.linspace(-2, 2.5, n, endpoint=False) + 2.25 / n
    X, Y = np.meshgrid(xs, ys)

    def inside(r, t, a, b):
        dx, dy = X - r[0], Y - r[1]
        R, _ = radius((np.arctan2(dy, dx) - t).ravel(), a, b)
        return np.hypot(dx, dy) < R.reshape(dx.shape)

    A_pix = np.sum(inside(ri, ti, a1, b1) & inside(rj, tj, a2, b2)) * (5 / n) * (4.5 / n)
    assert 0.3 < A < 1.0
    # pixel-count error ~ (boundary length ~3) * h^1.5 with h = 5e-3: ~1e-3 (observed 6e-5)
    assert A_pix == pytest.approx(A, abs=1e-3)


def test_area_symmetric_resolution_independent_and_arcs_consistent():
    rng = np.random.default_rng(2)
    a1, b1 = random_cell(rng, 0.6)
    a2, b2 = random_cell(rng, 0.5)
    args_ij = ([0, 0], 0.3, a1, b1, [1.1, 0.6], 2.0, a2, b2)
    args_ji = ([1.1, 0.6], 2.0, a2, b2, [0, 0], 0.3, a1, b1)
    A = overlap_area(*args_ij)
    assert overlap_area(*args_ji) == pytest.approx(A, abs=1e-14)
    for K in (256, 1024, 16384):  # crossings are bisected to 1e-15: no resolution dependence
        assert overlap_area(*args_ij, resolution=K) == pytest.approx(A, abs=1e-13)
    # Green's theorem by Gauss-Legendre quadrature on the returned arcs, independent of the
    # closed-form antiderivative: A = 1/2 [ int_i R_i^2 + int_j (R_j^2 + d x dx_j) ]
    x, w = np.polynomial.legendre.leggauss(60)
    total = 0.0
    for (r_s, t_s, a_s, b_s), (r_o, t_o, a_o, b_o) in (
        (([0, 0], 0.3, a1, b1), ([1.1, 0.6], 2.0, a2, b2)),
        (([1.1, 0.6], 2.0, a2, b2), ([0, 0], 0.3, a1, b1)),
    ):
        off = np.asarray(r_s, float)  # self centre relative to origin r_i = 0
        for s, t in inside_arcs(r_s, t_s, a_s, b_s, r_o, t_o, a_o, b_o):
            phi = 0.5 * (s + t) + 0.5 * (t - s) * x
            R, dR = radius(phi, a_s, b_s)
            lab = t_s + phi
            dx = dR * np.cos(lab) - R * np.sin(lab)
            dy = dR * np.sin(lab) + R * np.cos(lab)
            integrand = R * R + off[0] * dy - off[1] * dx
            total += 0.5 * np.sum(integrand * w) * 0.5 * (t - s)
    assert total == pytest.approx(A, abs=1e-12)


def test_no_overlap_and_coincident_cells():
    rng = np.random.default_rng(0)
    a1, b1 = random_cell(rng, 0.3)
    assert overlap_area([0, 0], 0.0, a1, b1, [5.0, 0.0], 0.0, a1, b1) == 0.0
    assert overlap_area([1, 2], 0.4, a1, b1, [1, 2], 0.4, a1, b1) == pytest.approx(np.pi, abs=1e-14)
    # same centre, different orientation: a proper intersection strictly below pi
    A = overlap_area([1, 2], 0.4, a1, b1, [1, 2], 1.4, a1, b1)
    assert 2.0 < A < np.pi


def test_periodic_pair_across_boundary_equals_pair_in_middle():
    rng = np.random.default_rng(4)
    a1, b1 = random_cell(rng, 0.3)
    a2, b2 = random_cell(rng, 0.3)
    box = (7.0, 6.0)
    A_mid = overlap_area([3.0, 3.0], 0.2, a1, b1, [4.4, 3.5], 1.2, a2, b2, box=box)
    A_wrap = overlap_area([6.3, 5.7], 0.2, a1, b1, [0.7, 0.2], 1.2, a2, b2, box=box)
    assert A_mid > 0.1
    assert A_wrap == pytest.approx(A_mid, abs=1e-14)


# ----------------------------------------------------------------------------- rates
def test_two_circles_force_is_chord():
    d, alpha = 1.3, 0.7
    pos = np.array([[0.0, 0.0], [d * np.cos(alpha), d * np.sin(alpha)]])
    r = reference_rates(pos, np.array([0.2, 1.0]), np.zeros((2, 5)), np.zeros((2, 5)),
                        eta=0.0, v0=0.0)
    chord = 2 * np.sqrt(1 - d * d / 4)
    u = pos[1] - pos[0]
    u /= np.linalg.norm(u)
    # dA/dd = -chord; 4-point FD with h = 1e-4: error ~ 1e-12/h + h^4 f^(5) ~ 1e-9
    np.testing.assert_allclose(r["dpos"][0], -chord * u, atol=1e-9)
    np.testing.assert_allclose(r["dpos"][1], chord * u, atol=1e-9)
    np.testing.assert_allclose(r["dtheta"], 0.0, atol=1e-9)  # circles: no torque


def test_shallow_contact_force_uses_small_step():
    # contact 1e-5 deep: the default step h = 1e-4 would step out of it; the per-pair step
    # (1e-2 x depth) keeps the stencil inside; round-off ~1e-15 / 1e-7 ~ 1e-8
    d = 2.0 - 1e-5
    pos = np.array([[0.0, 0.0], [d, 0.0]])
    r = reference_rates(pos, np.zeros(2), np.zeros((2, 5)), np.zeros((2, 5)), eta=0.0, v0=0.0)
    chord = 2 * np.sqrt(1 - d * d / 4)
    assert r["dpos"][1, 0] == pytest.approx(chord, abs=1e-7)
    assert r["dpos"][0, 0] == pytest.approx(-chord, abs=1e-7)


@pytest.fixture(scope="module")
def snap16():
    return dense_snapshot(16, density=0.95, seed=3, deform=0.3)


@pytest.fixture(scope="module")
def rates16(snap16):
    s = snap16
    return reference_rates(s["pos"], s["theta"], s["a"], s["b"], eta=0.05, v0=0.02, box=s["box"])


def test_reference_rates_match_model_md_formulas(snap16, rates16):
    # FD of the exact energy against docs/model.md's integrals (centroid, torque, dR/da_n =
    # R0 (cos n phi - a_n / 2a0), dP/da_n) evaluated on the exact arcs.  Observed 4e-9.
    s = snap16
    c = continuum_rates(s["pos"], s["theta"], s["a"], s["b"], eta=0.05, v0=0.02, box=s["box"])
    for k in ("dpos", "dtheta", "da", "db"):
        scale = np.abs(rates16[k]).max()
        assert scale > 0.1
        np.testing.assert_allclose(rates16[k], c[k], atol=1e-7 * scale, err_msg=k)


def test_action_reaction(snap16, rates16):
    s = snap16
    e = np.stack([np.cos(s["theta"]), np.sin(s["theta"])], axis=1)
    net = (rates16["dpos"] - 0.02 * e).sum(axis=0)
    assert np.abs(rates16["dpos"] - 0.02 * e).max() > 0.1
    np.testing.assert_allclose(net, 0.0, atol=1e-8)  # FD error per cell ~1e-9


def test_gradient_flow_directional_derivative(snap16, rates16):
    # with v0 = 0 and unit mobilities the rates are -grad H: dH/deps along them = -|grad|^2
    s = snap16
    g2 = sum(np.sum(rates16[k] ** 2) for k in ("grad_pos", "grad_theta", "grad_a", "grad_b"))
    eps = 1e-5
    Hs = []
    for sgn in (1.0, -1.0):
        Hs.append(exact_energy(s["pos"] - sgn * eps * rates16["grad_pos"],
                               s["theta"] - sgn * eps * rates16["grad_theta"],
                               s["a"] - sgn * eps * rates16["grad_a"],
                               s["b"] - sgn * eps * rates16["grad_b"], eta=0.05, box=s["box"]))
    slope = (Hs[0] - Hs[1]) / (2 * eps)
    assert slope == pytest.approx(-g2, rel=1e-6)  # central FD error ~ eps^2 |H'''|


def test_rotation_covariance():
    s = dense_snapshot(16, density=0.95, seed=7, deform=0.2)
    keep = np.argsort(np.linalg.norm(s["pos"] - s["pos"].mean(0), axis=1))[:7]  # open cluster
    pos, th, a, b = s["pos"][keep], s["theta"][keep], s["a"][keep], s["b"][keep]
    alpha = 0.83
    r1 = reference_rates(pos, th, a, b, eta=0.03, v0=0.05)
    r2 = reference_rates(rotate(pos, alpha) + [3.0, -1.0], th + alpha, a, b, eta=0.03, v0=0.05)
    np.testing.assert_allclose(r2["dpos"], rotate(r1["dpos"], alpha), atol=1e-8)
    for k in ("dtheta", "da", "db"):
        np.testing.assert_allclose(r2[k], r1[k], atol=1e-8, err_msg=k)


def test_periodic_rates_equal_shifted_copy():
    s = dense_snapshot(16, density=0.95, seed=11, deform=0.2)
    shift = 0.5 * s["box"] + 0.123
    r1 = reference_rates(s["pos"], s["theta"], s["a"], s["b"], eta=0.02, v0=0.0, box=s["box"])
    r2 = reference_rates(np.mod(s["pos"] + shift, s["box"]), s["theta"], s["a"], s["b"],
                         eta=0.02, v0=0.0, box=s["box"])
    for k in ("dpos", "dtheta", "da", "db"):
        np.testing.assert_allclose(r2[k], r1[k], atol=1e-8, err_msg=k)


def test_perimeter_fd_matches_perimeter_gradient():
    rng = np.random.default_rng(9)
    a, b = random_cell(rng, 0.5)
    r = reference_rates(np.zeros((1, 2)), np.zeros(1), a[None], b[None], eta=1.0, v0=0.0)
    dPa, dPb = perimeter_gradient(a[None], b[None])
    np.testing.assert_allclose(-r["da"], dPa, atol=1e-9)
    np.testing.assert_allclose(-r["db"], dPb, atol=1e-9)


# ----------------------------------------------------------------------------- snapshots
def test_dense_snapshot_properties():
    s = dense_snapshot(64, density=0.95, seed=0, deform=0.15)
    N = 64
    assert s["pos"].shape == (N, 2) and s["a"].shape == (N, 5) and s["theta"].shape == (N,)
    assert np.all((s["pos"] >= 0) & (s["pos"] < s["box"]))
    assert N * np.pi / np.prod(s["box"]) == pytest.approx(0.95)
    amp = amplitude_sum(s["a"], s["b"])
    assert np.all(amp < ADMISSIBLE_BOUND)
    assert amp.mean() == pytest.approx(0.15, rel=0.1)
    s2 = snapshot_from_arrays(s["pos"] + s["box"], s["theta"], s["a"], s["b"], s["box"])
    np.testing.assert_allclose(s2["pos"], s["pos"], atol=1e-12)
    with pytest.raises(ValueError):
        snapshot_from_arrays(s["pos"], s["theta"][:3], s["a"], s["b"], s["box"])


@pytest.mark.slow
def test_dense_64_cells_under_a_minute():
    s = dense_snapshot(64, density=0.95, seed=0, deform=0.15)
    t = time.perf_counter()
    r = reference_rates(s["pos"], s["theta"], s["a"], s["b"], eta=0.05, v0=0.0, box=s["box"])
    assert time.perf_counter() - t < 60.0
    np.testing.assert_allclose(r["dpos"].sum(axis=0), 0.0, atol=1e-8)
