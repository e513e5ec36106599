"""The per-run observables from arrays alone (no file): fcsweep.analysis.run_observables."""

from __future__ import annotations

import numpy as np
import pytest

from fcsweep.analysis.phase import PERCOLATION_FLAGS, PHASE_FLAGS
from fcsweep.analysis.run_observables import AnalysisError, RunFrames, compute_observables, frame_plan
from fcsweep.analysis.shapes import Q_CIRCLE
from fcsweep.model.lattice import hexagonal_lattice
from fcsweep.model.observables import REASONS, RUN_SCALARS
from fcsweep.results.analyze import settings_with


def _crystal(T: int = 120, N: int = 64, jitter: float = 0.01, seed: int = 3) -> tuple[RunFrames, dict]:
    """Rigid discs vibrating about a triangular lattice: no cell leaves its site."""
    s = settings_with({"structure_frames": 20, "correlation_frames": 2, "shape_frames": 20}, transient=0.2)
    plan = frame_plan(T, s)
    lattice, box = hexagonal_lattice(N)
    rng = np.random.default_rng(seed)
    x = lattice[None] + jitter * rng.standard_normal((T, N, 2))  # (T, N, 2), never wrapped
    run = RunFrames(source="crystal", params={"R0": 1.0, "v0": 0.02, "Dr": 0.1, "modes": 0}, box=box,
                    time=np.arange(T) * 5.0, plan=plan, shape_a=None, shape_b=None, rigid=True,
                    positions=np.mod(x[plan.structure_frames], box), unwrapped=x[plan.frames])
    return run, s


def test_a_vibrating_crystal_is_a_solid_without_defects():
    """Arrays in, numbers out: q of a circle, no defects, |Psi6| near 1, a caged solid."""
    run, s = _crystal()
    sc, cv, extra = compute_observables(run, s, curves=False, psi6=True)
    assert set(RUN_SCALARS) <= set(sc) and set(REASONS) <= set(sc)
    assert sc["q_mean"] == pytest.approx(Q_CIRCLE, abs=1e-12) and sc["q_std"] == pytest.approx(0.0, abs=1e-12)
    assert sc["rho_d"] == 0.0
    assert sc["psi6"] > 0.95  # jitter 0.01 of a spacing ~1.9: bond angles within a degree
    assert PHASE_FLAGS[int(sc["phase"])] == "solid", sc["phase_reason"]
    assert PERCOLATION_FLAGS[int(sc["percolated"])] == "not_percolated"
    assert extra["frames"][0] == 24 and extra["frames"][-1] == 119  # ceil(0.2 * 119) = 24
    assert not set(cv) & {"msd", "G6", "Gr"}  # no curves asked for


def test_too_few_frames_and_uneven_times_are_refused():
    s = settings_with(transient=0.5)
    with pytest.raises(AnalysisError, match="only 2 frames after the transient"):
        frame_plan(4, s, source="short")
    run, s = _crystal(T=40)
    t = run.time.copy()
    t[-1] += 1.0
    uneven = RunFrames(**{**run.__dict__, "time": t})
    with pytest.raises(AnalysisError, match="not equally spaced"):
        compute_observables(uneven, s, curves=False, psi6=False)
