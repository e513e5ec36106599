"""Not solid from the cage-relative F_s: where F_s(2 pi / a) falls below 1/e by the lag at
which a state at the solid threshold (D_eff = 1e-3) could at the earliest have relaxed, the
phase rule reads not solid without waiting for the cage-relative MSD to pass a^2.

Known answers (tests/synthetic.py ``creeping_lattice``, 256 cells, v0 = 0.03, Dr = 0.01):
Gaussian creep at D_eff = 2e-3 is decided fluid at 2000 time units (the cage-relative MSD
reaches a^2 at t* ~ 9 100); Gaussian creep at 5e-4 stays solid; the hopping lattice
(non-Gaussian: F_s decays later at the same D) is not decided by this rule, whatever D.
"""

import numpy as np
from synthetic import creeping_lattice

from fcsweep.analysis.cage import cage_breaking
from fcsweep.analysis.phase import PHASE_FLUID, PHASE_SOLID, phase_evidence, phase_label, relaxed_probability

V0, DR = 0.03, 0.01
D0 = V0 ** 2 / (2 * DR)


def _label(D_eff, span, gaussian, seed=0):
    t, x, box = creeping_lattice(D_eff * D0, np.random.default_rng(seed), span=span, gaussian=gaussian)
    cb = cage_breaking(t, x, box)
    sc = {**cb.scalars(V0, DR), "D_eff_cr": cb.D_cr / D0, "D_eff_cr_err": cb.D_cr_err / D0,
          "msd_long_enough": 1.0, "msd_diffusive": 1.0, "q_mean": 3.6, "q_mean_err": 0.002}
    return phase_label(phase_evidence(sc)), sc, cb


def test_the_relaxation_lag_is_that_of_a_gaussian_state_at_the_threshold():
    _, sc, cb = _label(2e-3, 2000.0, True)
    a2 = cb.spacing ** 2
    expected = a2 / (4 * np.pi ** 2 * 1e-3 * D0 * (1 + cb.inv_neighbours))
    assert sc["relaxation_lag"] == expected and 1700 < expected < 2000


def test_gaussian_creep_above_the_threshold_is_decided_long_before_its_cages_break():
    lab, sc, cb = _label(2e-3, 2000.0, True)
    assert cb.p_broken < 0.05  # the cage test alone would wait ~9 100 time units
    assert lab.code == PHASE_FLUID and lab.reason_code == "decided_relaxed", lab.reason
    assert sc["F_s_bound"] < np.exp(-1) - 5 * sc["F_s_bound_err"]  # exp(-2) = 0.135 expected, 0.215 measured


def test_slow_gaussian_creep_and_hops_are_not_decided_by_it():
    lab, sc, _ = _label(5e-4, 4000.0, True)
    assert relaxed_probability(sc) < 0.01 and lab.code == PHASE_SOLID  # F_s(lag) = exp(-1/2) expected
    lab, sc, _ = _label(2e-3, 4000.0, False)
    assert relaxed_probability(sc) < 0.01 and lab.reason_code != "decided_relaxed"


def test_a_window_shorter_than_the_relaxation_lag_measures_nothing():
    _, sc, _ = _label(2e-3, 1000.0, True)
    assert np.isnan(sc["F_s_bound"]) and np.isnan(relaxed_probability(sc))
