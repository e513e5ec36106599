"""The contour rule's and the step's measured systematic offsets are in the labels: a label
that an offset in the measured range could flip is undetermined (reason code ``rule_sensitive``)."""

from __future__ import annotations

import numpy as np
import pytest

from fcsweep.analysis.phase import (PHASE_FLUID, PHASE_SOFT_FLUID, PHASE_SOLID, PHASE_UNDETERMINED, phase_evidence,
                                    phase_label)
from fcsweep.analysis.points import point_labels
from fcsweep.model.systematics import rule_bias

#: A flowing run (cages broken, D_eff_cr_late far above 1e-3) at eta = 0.02, v0 = 0.06, N = 1024:
#: the binary rule read <q> = 3.859, the arc rule 3.806 (the paper campaign's arc-vs-binary cut).
FLOWING = {"cage_msd_ratio": 3.0, "cage_msd_ratio_err": 0.1, "D_eff_cr_late": 0.05, "D_eff_cr_late_err": 0.005,
           "D_eff_cr": 0.05, "D_eff_cr_err": 0.005, "msd_long_enough": 1.0, "msd_diffusive": 1.0,
           "q_mean_err": 0.001}
#: A caged run whose cage-relative D_eff is just below the solid threshold.
CAGED = {"cage_msd_ratio": 0.02, "cage_msd_ratio_err": 0.01, "D_eff_cr": 9.0e-4, "D_eff_cr_err": 1e-5,
         "msd_long_enough": 1.0, "msd_diffusive": 1.0, "q_mean": 3.6, "q_mean_err": 0.001}


def _label(sc, quadrature="binary", K=40, dt=0.005, modes=6):
    return phase_label(phase_evidence({**sc, **rule_bias(quadrature, K, dt, modes)}))


def test_binary_is_not_decided_soft_fluid_against_arcs_fluid():
    binary = _label({**FLOWING, "q_mean": 3.859})
    assert binary.code == PHASE_UNDETERMINED and binary.reason_code == "rule_sensitive", binary.reason
    assert "between 3.7860 and 3.8370" in binary.reason
    arc = _label({**FLOWING, "q_mean": 3.806}, quadrature="arc")
    assert arc.code == PHASE_FLUID and arc.confidence > 0.999
    # as measured, without the offsets, binary read soft fluid at P = 1: the flip the rule prevents
    assert phase_label(phase_evidence({**FLOWING, "q_mean": 3.859})).code == PHASE_SOFT_FLUID


def test_far_from_the_lines_the_offsets_change_nothing():
    assert _label({**FLOWING, "q_mean": 3.956}).code == PHASE_SOFT_FLUID  # the demo's soft fluid
    assert _label({**FLOWING, "q_mean": 3.60}).code == PHASE_FLUID
    assert _label({**CAGED, "D_eff_cr": 2e-4}).code == PHASE_SOLID


def test_a_coarse_step_makes_a_solid_near_the_threshold_rule_sensitive():
    """At dt = 0.01 the measured D is 0-17 % low: 9e-4 measured is 9e-4 .. 1.08e-3 converged."""
    assert _label(CAGED, quadrature="arc", dt=0.005).code == PHASE_SOLID
    lab = _label(CAGED, quadrature="arc", dt=0.01)
    assert lab.reason_code == "rule_sensitive" and "on both sides of 0.001" in lab.reason
    unmeasured = _label({**CAGED, "D_eff_cr": 2e-4}, quadrature="arc", dt=0.04)
    assert unmeasured.reason_code == "rule_sensitive" and "not measured" in unmeasured.reason


@pytest.mark.parametrize("quadrature, K, dt, modes, q", [("arc", 40, 0.005, 6, (0.0, 0.0)),
                                                          ("binary", 80, 0.005, 6, (0.0, 0.005)),
                                                          ("binary", 40, 0.005, 6, (0.022, 0.073)),
                                                          ("linear", 40, 0.005, 6, (0.093, 0.105)),
                                                          ("binary", 40, 0.0, 0, (0.0, 0.0))])
def test_the_declared_offsets(quadrature, K, dt, modes, q):
    b = rule_bias(quadrature, K, dt or 0.005, modes)
    assert (b["q_bias_low"], b["q_bias_high"]) == q


def test_a_point_takes_the_widest_offset_range_of_its_replicates():
    runs = [{**FLOWING, "q_mean": 3.859, **rule_bias("binary", 40, 0.005)}] * 2
    assert point_labels(runs)[0].reason_code == "rule_sensitive"
    unmeasured = {**FLOWING, "q_mean": 3.60, **rule_bias("arc", 40, 0.04)}
    lab = point_labels([unmeasured, {**FLOWING, "q_mean": 3.60}])[0]
    assert lab.reason_code == "rule_sensitive" and np.isnan(lab.confidence)


def test_analyses_without_the_offsets_keep_their_labels():
    """NaN offsets (a dataset holding analyses made before they were stored) read as none."""
    nan = dict.fromkeys(("q_bias_low", "q_bias_high", "d_bias_low", "d_bias_high"), float("nan"))
    assert phase_label(phase_evidence({**FLOWING, "q_mean": 3.859, **nan})).code == PHASE_SOFT_FLUID
    assert point_labels([{**CAGED, **nan}])[0].code == PHASE_SOLID
