"""Phase behaviour the paper reports, on small systems (docs/model.md, 'What the paper reports').

These are physics regression checks of the whole engine: a stiff, slow population is a
solid (caged: the MSD saturates far below one cell area), a soft, fast one is a soft
fluid (cells migrate over several radii and are elongated, <q> > 3.81).
"""

import numpy as np
import pytest

from fcsweep.analysis.diffusion import effective_diffusion, estimate_diffusion
from fcsweep.analysis.msd import msd_curve
from fcsweep.model.shape import Q_STAR, shape_index
from fcsweep.simulation import Simulation


def run(N, eta, v0, warm, frames, every, quadrature="binary"):
    s = Simulation.from_lattice(N, eta=eta, v0=v0, Dr=0.01, seed=1, quadrature=quadrature)
    s.advance(warm)
    x, q = [], []
    for _ in range(frames):
        s.advance(every)
        x.append(s.state.unwrapped().copy())
        q.append(shape_index(s.state.a, s.state.b, points=256).mean())
    msd, _ = msd_curve(np.array(x))
    t = np.arange(frames) * every * s.params.dt
    fit = estimate_diffusion(t, np.array(x), Dr=0.01)
    D_eff, err = effective_diffusion(fit.D, fit.D_err, v0, 0.01)
    return msd, D_eff, err, float(np.mean(q))


def test_solid_and_soft_fluid_small_system():
    """N = 64, 100 time units after 20: measured MSD(100) = 0.002 vs 3.2 R0^2,
    <q> = 3.56 vs 3.97, D_eff = 1.0e-3 vs 3.0e-2."""
    msd_s, De_s, _, q_s = run(64, 0.1, 0.01, 4000, 200, 100)
    msd_f, De_f, _, q_f = run(64, 0.01, 0.06, 4000, 200, 100)
    assert msd_s[-1] < 0.05  # caged: far below a cell area (pi R0^2)
    assert msd_f[-1] > 1.0  # migrates over more than a radius
    assert q_s < Q_STAR < q_f
    assert De_f > 10 * De_s


@pytest.mark.slow
@pytest.mark.parametrize("quadrature", ["binary", "arc"])
def test_solid_and_soft_fluid_longer_runs_both_quadratures(quadrature):
    """N = 144, 300 time units after 50: the soft-fluid corner (eta = 0.01, v0 = 0.06)
    is labelled soft fluid (D_eff > 1e-3, <q> > 3.81); the solid corner (eta = 0.1,
    v0 = 0.01) stays caged. 300 time units are 3/Dr, shorter than one D_eff time block
    (4/Dr), so the solid check is the cage: MSD below 0.1 R0^2 and 10x less mobile
    than the soft fluid."""
    msd_s, De_s, _, q_s = run(144, 0.1, 0.01, 10000, 300, 200, quadrature)
    msd_f, De_f, _, q_f = run(144, 0.01, 0.06, 10000, 300, 200, quadrature)
    assert De_f > 1e-3 and q_f > Q_STAR
    assert q_s < Q_STAR
    assert msd_s[-1] < 0.1 and De_f > 10 * De_s  # measured: MSD 0.008 R0^2, ratio 26-29
