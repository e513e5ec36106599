"""Adhesion (docs/model.md, "Adhesion"): the numpy reference against finite differences
of its energy, the numba kernel against the reference, the off switch, and the balance
an adhered pair of discs reaches."""

import numpy as np
import pytest
from scipy.optimize import brentq

from conftest import dense_config
from fcsweep.kernels.api import kernel_rates
from fcsweep.model.adhesion import adhesion_energy, adhesion_rates, smooth_step
from fcsweep.model.rates import rates

KEYS = ("dpos", "dtheta", "da", "db")


def _with_adhesion(pos, theta, a, b, *, adhesion, adhesion_range, **kw):
    """The reference: today's rates plus the adhesion terms."""
    r = rates(pos, theta, a, b, **kw)
    ad = adhesion_rates(pos, theta, a, b, adhesion=adhesion, adhesion_range=adhesion_range,
                        **{k: v for k, v in kw.items() if k not in ("eta", "v0", "quadrature")})
    return {k: r[k] + ad[k] for k in KEYS}


def test_smooth_step_is_continuous_with_its_derivative():
    """w = 1 inside, 0 beyond the range, w and w' continuous at both ends, w' the slope."""
    d = 0.1
    h = np.array([-1e-12, 0.0, 1e-12, d - 1e-12, d, d + 1e-12])
    w, dw = smooth_step(h, d)
    assert np.allclose(w, [1, 1, 1, 0, 0, 0], atol=1e-9) and np.allclose(dw, 0, atol=1e-9)
    x = np.linspace(-0.05, 0.15, 41)
    eps = 1e-7
    fd = (smooth_step(x + eps, d)[0] - smooth_step(x - eps, d)[0]) / (2 * eps)
    # w'' jumps by 6/delta^2 at both ends: there the central difference is off by ~1.5e-5
    assert np.allclose(fd, smooth_step(x, d)[1], atol=5e-5)


@pytest.mark.parametrize("M1", [0, 5])
def test_reference_rates_are_minus_the_energy_gradient(M1):
    """Central differences of E_adh (step 1e-6, error ~1e-10 relative to O(1) rates) give
    the reference's centre, angle and mode rates, times the mobilities."""
    rng = np.random.default_rng(1)
    pos = np.array([[0.0, 0.0], [2.03, 0.1], [0.9, 1.85]])
    th = rng.uniform(0, 2 * np.pi, 3)
    a = rng.normal(0, 0.05, (3, M1))
    b = rng.normal(0, 0.05, (3, M1))
    ekw = dict(adhesion=0.7, adhesion_range=0.2, contour_points=40)
    r = adhesion_rates(pos, th, a, b, mu_theta=1.3, mu_shape=0.8, **ekw)

    def grad(x, *where):
        out = np.zeros(x.shape)
        for idx in np.ndindex(x.shape):
            xp, xm = x.copy(), x.copy()
            xp[idx] += 1e-6
            xm[idx] -= 1e-6
            args = [xp if w else y for w, y in zip(where, (pos, th, a, b))]
            argm = [xm if w else y for w, y in zip(where, (pos, th, a, b))]
            out[idx] = (adhesion_energy(*args, **ekw) - adhesion_energy(*argm, **ekw)) / 2e-6
        return out

    assert np.allclose(r["dpos"], -grad(pos, 1, 0, 0, 0), atol=1e-7)
    assert np.abs(r["dpos"]).max() > 0.1
    if M1:
        assert np.allclose(r["dtheta"], -1.3 * grad(th, 0, 1, 0, 0), atol=1e-7)
        assert np.allclose(r["da"], -0.8 * grad(a, 0, 0, 1, 0), atol=1e-7)
        assert np.allclose(r["db"], -0.8 * grad(b, 0, 0, 0, 1), atol=1e-7)
    assert adhesion_energy(pos, th, a, b, **ekw) < 0


@pytest.mark.parametrize("quadrature", ["binary", "arc"])
@pytest.mark.parametrize("N,M1,deform", [(16, 5, 0.1), (64, 5, 0.15), (64, 7, 0.2), (16, 0, 0.0)])
def test_kernel_equals_reference(quadrature, N, M1, deform):
    """The kernel's rates with adhesion equal today's reference plus the adhesion
    reference to round-off (1e-11 of the largest rate), through the neighbour list
    (N = 64, built to reach the range), the all-image path (N = 16), generic M (M1 = 7)
    and rigid discs (M1 = 0)."""
    pos, theta, a, b, box = dense_config(N, seed=N + M1, deform=deform, M1=M1, density=0.85)
    kw = dict(eta=0.05, v0=0.03, box=box, contour_points=40, quadrature=quadrature, mu_theta=1.2, mu_shape=0.9)
    ref = _with_adhesion(pos, theta, a, b, adhesion=0.3, adhesion_range=0.25, **kw)
    got = kernel_rates(pos, theta, a, b, adhesion=0.3, adhesion_range=0.25, **kw)
    off = kernel_rates(pos, theta, a, b, **kw)
    for k in KEYS:
        if ref[k].size == 0:
            continue
        scale = max(1.0, np.abs(ref[k]).max())
        assert np.abs(ref[k] - got[k]).max() <= 1e-11 * scale, k
    assert np.abs(got["dpos"] - off["dpos"]).max() > 0.05  # adhesion acts in these states


def test_zero_adhesion_leaves_rates_bit_identical():
    """adhesion = 0 (any range) gives today's rates to the last bit."""
    pos, theta, a, b, box = dense_config(64, seed=2)
    kw = dict(eta=0.05, v0=0.03, box=box)
    off = kernel_rates(pos, theta, a, b, **kw)
    zero = kernel_rates(pos, theta, a, b, adhesion=0.0, adhesion_range=0.4, **kw)
    for k in KEYS:
        assert np.array_equal(off[k], zero[k])


def _disc_balance(gamma, delta, R0=1.0):
    """Distance d of two adhered discs where the lens chord balances the adhesion pull,
    from the continuum energy E(d) = A(d) - 2 gamma R0 int w(h(phi; d)) dphi (both
    contours), h = |x - r_j| - R0 for x = R0 e(phi), r_j = (d, 0): independent of the
    kernels and the reference's point quadrature."""
    phi = np.linspace(-np.pi, np.pi, 200001)

    def residual(d):
        dist = np.sqrt(R0 * R0 + d * d - 2 * R0 * d * np.cos(phi))
        _, dw = smooth_step(dist - R0, delta)
        pull = -2 * gamma * R0 * np.trapezoid(dw * (d - R0 * np.cos(phi)) / dist, phi)
        return 2 * np.sqrt(max(R0 * R0 - d * d / 4, 0.0)) - pull

    return brentq(residual, 2 * R0 - 0.5, 2 * R0)


def _relax_pair(gamma, delta, d0, K, M1=0, eta=0.0, steps=3000, dt=5e-3):
    """Euler relaxation of two cells at v0 = 0 with the kernels; their final distance and
    shapes."""
    pos = np.array([[0.0, 0.0], [d0, 0.0]])
    th = np.array([0.0, np.pi])
    a = np.zeros((2, M1))
    b = np.zeros((2, M1))
    for _ in range(steps):
        r = kernel_rates(pos, th, a, b, eta=eta, v0=0.0, contour_points=K, adhesion=gamma, adhesion_range=delta)
        pos += dt * r["dpos"]
        th += dt * r["dtheta"]
        a += dt * r["da"]
        b += dt * r["db"]
    return float(np.hypot(*(pos[1] - pos[0]))), a, b


def test_adhered_discs_reach_the_derived_contact_and_it_grows_with_strength():
    """Two rigid discs placed just out of contact (gap delta/2) at v0 = 0 are pulled
    together and settle where the chord balances the adhesion pull of the continuum
    energy; the contact (chord) grows with gamma.  K = 320 resolves the band of width
    delta = 0.1 where it crosses the other disc by ~6 points: the point-quadrature error
    on the chord is 0.1-0.4 % there (3.4 % at K = 160, 0.1 % at K = 640 for gamma = 0.2)."""
    delta = 0.1
    chords = []
    for gamma in (0.05, 0.1, 0.2):
        d_star = _disc_balance(gamma, delta)
        d, _, _ = _relax_pair(gamma, delta, 2.0 + 0.5 * delta, K=320, steps=2000, dt=2e-3)
        chord, chord_star = 2 * np.sqrt(1 - d * d / 4), 2 * np.sqrt(1 - d_star * d_star / 4)
        assert d < 2.0  # pulled into contact
        assert chord == pytest.approx(chord_star, rel=0.01)
        chords.append(chord)
    assert chords[0] < chords[1] < chords[2]


def test_deformable_pair_adheres_longer_with_stronger_adhesion():
    """Two deformable cells (M = 6, eta = 0.1) set 0.05 R0 apart at v0 = 0: without
    adhesion they stay apart; with it they are pulled into contact, and the adhered
    length L = -E_adh / gamma of the relaxed pair grows with gamma, as it must for
    minimisers of E_0 - gamma L (comparing the two minimum conditions at gamma < gamma'
    gives (gamma' - gamma)(L' - L) >= 0).  7.5 time units relax L to 1e-3 (checked
    against 20)."""
    lengths = []
    for gamma in (0.0, 0.02, 0.05, 0.1):
        d, a, b = _relax_pair(gamma, 0.1, 2.05, K=40, M1=5, eta=0.1, steps=1500, dt=5e-3)
        if gamma == 0.0:
            assert d == pytest.approx(2.05, abs=1e-12)
            continue
        assert d < 2.0
        pos = np.array([[0.0, 0.0], [d, 0.0]])
        th = np.array([0.0, np.pi])
        lengths.append(-adhesion_energy(pos, th, a, b, adhesion=1.0, adhesion_range=0.1, contour_points=40))
    assert np.all(np.diff(lengths) > 0.02)


SWEEP = """
output: {out}
seed: 5
grid:
  v0: [0.03]
  {grid}
model: {{N: 16, eta: 0.1, quadrature: binary{model}}}
run: {{steps: 40, sample_every: 20, checkpoint_every: 20}}
"""


def test_adhesion_zero_keeps_run_ids_seeds_and_trajectory(tmp_path):
    """A config with ``adhesion: 0`` (and the default range) written out has the run ids
    and seeds of one without the keys, and its run is the same to the last bit."""
    import h5py

    from fcsweep.config import parse_config
    from fcsweep.io.h5md import read_parameters
    from fcsweep.sweep.executors import run_sweep

    plain = parse_config(SWEEP.format(out=tmp_path / "a", grid="", model=""))
    zero = parse_config(SWEEP.format(out=tmp_path / "b", grid="", model=", adhesion: 0.0, adhesion_range: 0.1"))
    assert [(s.run_id, s.seed) for s in plain.runs()] == [(s.run_id, s.seed) for s in zero.runs()]
    trajs = []
    for cfg in (plain, zero):
        assert [o.outcome for o in run_sweep(cfg, cfg.runs())] == ["done"]
        trajs.append(next(cfg.output.rglob("trajectory.h5")))
    with h5py.File(trajs[0], "r") as fa, h5py.File(trajs[1], "r") as fb:
        names = []
        fa["particles/cells"].visit(names.append)
        values = [n for n in names if n.endswith("/value")]
        assert "position/value" in values
        for n in values:
            assert np.array_equal(fa["particles/cells"][n][()], fb["particles/cells"][n][()]), n
    assert read_parameters(trajs[0])["adhesion"] == 0.0


def test_adhesion_is_a_sweepable_coordinate_carried_in_the_trajectory(tmp_path):
    """``grid: {adhesion: [...]}`` gives one run per strength with its own id; the
    trajectory's /parameters carry adhesion and adhesion_range."""
    from fcsweep.config import parse_config
    from fcsweep.io.h5md import read_parameters
    from fcsweep.sweep.executors import run_sweep

    cfg = parse_config(SWEEP.format(out=tmp_path, grid="adhesion: [0.0, 0.1]", model=", adhesion_range: 0.2"))
    runs = cfg.runs()
    assert len({s.run_id for s in runs}) == 2 and [s.params["adhesion"] for s in runs] == [0.0, 0.1]
    assert [o.outcome for o in run_sweep(cfg, runs)] == ["done", "done"]
    got = sorted((read_parameters(p)["adhesion"], read_parameters(p)["adhesion_range"])
                 for p in cfg.output.rglob("trajectory.h5"))
    assert got == [(0.0, 0.2), (0.1, 0.2)]


@pytest.mark.parametrize("key,value,match", [("adhesion", -0.1, r"model\.adhesion = -0\.1"),
                                              ("adhesion_range", 0.0, r"model\.adhesion_range = 0"),
                                              ("adhesion_range", 0.6, r"model\.adhesion_range = 0\.6")])
def test_adhesion_values_out_of_range_are_refused_naming_the_key(tmp_path, key, value, match):
    from fcsweep.config import ConfigError, parse_config

    with pytest.raises(ConfigError, match=match):
        parse_config(SWEEP.format(out=tmp_path, grid="", model=f", {key}: {value}"))
