"""Movie labels with the simulations' rules (:mod:`fcsweep.analysis.phase`): percolated from
the movie's rho_d with its error, and the phase from the cages, D_eff and <q>.

With ``v0`` and ``Dr`` (so D_eff) the phase is the simulations' rule
(:func:`fcsweep.analysis.phase.classify_phase` with the cage evidence): broken cages and
the cage-relative D_eff past the breaking decide solid against not solid, <q> fluid against
soft fluid.  Without them (images do not give D0 = v0^2 / (2 Dr)) only broken cages
decide: "not solid", then fluid or soft fluid from <q>; intact cages leave the phase
undetermined (solid needs D_eff), and the reason says so.
"""

from __future__ import annotations

import numpy as np

from fcsweep.analysis.phase import (MIN_CONFIDENCE, PERCOLATION_FLAGS, PHASE_FLAGS, PHASE_FLUID, PHASE_SOFT_FLUID,
                                    PHASE_UNDETERMINED, PHASE_UNKNOWN, Label, p_above, classify_percolation,
                                    classify_phase, flag_attrs)
from fcsweep.model.shape import Q_STAR

__all__ = ["movie_labels"]


def movie_labels(values: dict, *, threshold: float, min_confidence: float = MIN_CONFIDENCE) -> dict:
    """``{name: (code, confidence, reason, flag attrs)}`` for ``percolated`` and ``phase``.

    Parameters
    ----------
    values : dict
        ``rho_d_movie``, ``rho_d_movie_err``, ``q_mean_movie``, ``q_mean_movie_err``,
        ``D_eff``, ``D_eff_err``, ``D_s_diffusive``.
    threshold : float
        rho_d above which the movie is percolated.
    """
    perc = classify_percolation(values["rho_d_movie"], values["rho_d_movie_err"], threshold=threshold,
                                min_confidence=min_confidence)
    p_broken = values.get("cage_broken_probability", float("nan"))
    if np.isfinite(values["D_eff"]):
        diffusive = values["D_s_diffusive"] == 1
        phase = classify_phase(values["D_eff"], values["D_eff_err"], values["q_mean_movie"],
                               values["q_mean_movie_err"], diffusion_ok=diffusive,
                               diffusion_note="" if diffusive else ("the MSD slope has not settled or the "
                                                                    "movie is shorter than 8 / Dr"),
                               cage_broken=p_broken, D_late=values.get("D_eff_cr_late", float("nan")),
                               D_late_err=values.get("D_eff_cr_late_err", float("nan")),
                               min_confidence=min_confidence)
    elif np.isfinite(p_broken) and p_broken >= min_confidence:
        phase = _fluid_from_q(values["q_mean_movie"], values["q_mean_movie_err"], p_broken, min_confidence)
    elif np.isfinite(p_broken):
        phase = Label(PHASE_UNDETERMINED, float("nan"), f"cages not broken (P = {p_broken:.2f}): solid needs "
                                                        "D_eff, give --v0 and --Dr", "cages_intact_no_d_eff")
    else:
        phase = Label(PHASE_UNKNOWN, float("nan"), "no cage test (3 frames and 4 tracked cells needed) and no "
                                                   "D_eff (give --v0 and --Dr)", "not_available")
    return {"percolated": (perc.code, perc.confidence, perc.reason, flag_attrs(PERCOLATION_FLAGS)),
            "phase": (phase.code, phase.confidence, phase.reason, flag_attrs(PHASE_FLAGS))}


def _fluid_from_q(q, q_err, p_broken, min_confidence) -> Label:
    """Broken cages without D_eff: not solid; fluid or soft fluid from <q> with its error."""
    why = f"cages broken (P = {p_broken:.3f}), D_eff unknown (no --v0, --Dr)"
    if not (np.isfinite(q) and np.isfinite(q_err)):
        return Label(PHASE_UNDETERMINED, float("nan"), f"{why}; <q> has no error", "no_error")
    p = p_above(float(q), float(q_err), Q_STAR) * p_broken
    conf = max(p, p_broken - p)
    if conf < min_confidence:
        return Label(PHASE_UNDETERMINED, conf, f"{why}; <q> too close to {Q_STAR}", "near_q_star")
    code = PHASE_SOFT_FLUID if p >= p_broken - p else PHASE_FLUID
    return Label(code, conf, f"{why}: P({PHASE_FLAGS[code]}) = {conf:.3f}", "decided_q_no_d_eff")
