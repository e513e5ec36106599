"""A label is decided only on a stationary window: where the equilibration cut reaches its
limit (half the frames after the transient), the series still drifts, and the phase and
percolation labels are undetermined with reason code ``not_stationary``."""

from __future__ import annotations

import numpy as np

from fcsweep.analysis.phase import classify_percolation, phase_evidence, phase_label
from fcsweep.analysis.points import point_labels
from fcsweep.analysis.run_observables import cut_at_limit, equilibrated_frames
from fcsweep.analysis.stats import detect_equilibration

#: A solid's evidence, decided at P = 1 when its window is stationary.
SOLID = {"D_eff": 2e-4, "D_eff_err": 1e-5, "D_eff_cr": 1e-4, "D_eff_cr_err": 1e-5, "msd_long_enough": 1.0,
         "msd_diffusive": 1.0, "q_mean": 3.6, "q_mean_err": 1e-3, "cage_msd_ratio": 0.01,
         "cage_msd_ratio_err": 0.001, "rho_d": 0.05, "rho_d_err": 0.01}


def test_a_drifting_series_is_cut_at_the_limit_and_a_stationary_one_is_kept_whole():
    rng = np.random.default_rng(1)
    n = 200
    frames = np.arange(40, 40 + n)
    drift = 0.3 - 0.2 * np.arange(n) / n + 0.005 * rng.standard_normal(n)  # an ageing packing's rho_d
    flat = 0.3 + 0.005 * rng.standard_normal(n)
    settles = np.where(np.arange(n) < 30, 0.5, 0.3) + 0.005 * rng.standard_normal(n)  # a transient, then flat
    starts = {name: frames[detect_equilibration(x)] for name, x in
              (("drift", drift), ("flat", flat), ("settles", settles))}
    assert cut_at_limit(frames, [starts["drift"]])
    assert not cut_at_limit(frames, [starts["flat"]]) and starts["flat"] == frames[0]
    assert not cut_at_limit(frames, [starts["settles"]]) and starts["settles"] > frames[0]
    assert equilibrated_frames(frames, [starts["drift"]])[0] == frames[(n - 1) // 2]  # the cap


def test_no_label_is_decided_on_a_drifting_window():
    assert phase_label(phase_evidence(SOLID)).reason_code == "solid_cages_intact"
    lab = phase_label(phase_evidence({**SOLID, "equilibration_at_limit": 1.0}))
    assert lab.reason_code == "not_stationary" and lab.code == 3 and np.isnan(lab.confidence)
    perc = classify_percolation(0.05, 0.01, stationary=False)
    assert perc.reason_code == "not_stationary" and np.isnan(perc.confidence)
    assert classify_percolation(0.05, 0.01).reason_code == "decided_rho_d"


def test_analyses_before_the_flag_read_as_stationary():
    """analysis.h5 files written before the flag existed have no ``equilibration_at_limit``:
    their labels are unchanged."""
    assert "equilibration_at_limit" not in SOLID
    assert phase_label(phase_evidence(SOLID)).code == 0


def test_a_point_is_undetermined_when_one_replicate_drifts():
    phase, perc = point_labels([SOLID, {**SOLID, "equilibration_at_limit": 1.0}])
    assert phase.reason_code == "not_stationary" and perc.reason_code == "not_stationary"
    phase, perc = point_labels([SOLID, SOLID])
    assert phase.code == 0 and perc.code == 0
