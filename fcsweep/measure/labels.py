"""Movie labels with the simulations' rules (:mod:`fcsweep.analysis.phase`): percolated from
the movie's rho_d with its error, and the phase from D_eff and <q> where D_eff exists.

The simulations decide solid / fluid from cage-relative displacements; a cage analysis of
images is not built yet, so here the phase is the plain D_eff test
(:func:`fcsweep.analysis.phase.classify_phase` without cage evidence): solid if
D_eff < 1e-3, else soft fluid if <q> > 3.81, else fluid, each with its probability.  D_eff
needs the free-cell diffusion D0 = v0^2 / (2 Dr), which images do not give: without
``v0`` and ``Dr`` the phase is unknown and the reason says so.
"""

from __future__ import annotations

import numpy as np

from fcsweep.analysis.phase import (MIN_CONFIDENCE, PERCOLATION_FLAGS, PHASE_FLAGS, PHASE_UNKNOWN, Label,
                                    classify_percolation, classify_phase, flag_attrs)

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
    if np.isfinite(values["D_eff"]):
        diffusive = values["D_s_diffusive"] == 1
        phase = classify_phase(values["D_eff"], values["D_eff_err"], values["q_mean_movie"],
                               values["q_mean_movie_err"], diffusion_ok=diffusive,
                               diffusion_note="" if diffusive else ("the MSD slope has not settled or the "
                                                                    "movie is shorter than 8 / Dr"),
                               min_confidence=min_confidence)
        phase = Label(phase.code, phase.confidence, f"plain D_eff test (no cage analysis of images): {phase.reason}")
    else:
        phase = Label(PHASE_UNKNOWN, float("nan"), "D_eff needs the free-cell diffusion: give --v0 and --Dr "
                                                   "(and a tracked movie of 3 frames or more)")
    return {"percolated": (perc.code, perc.confidence, perc.reason, flag_attrs(PERCOLATION_FLAGS)),
            "phase": (phase.code, phase.confidence, phase.reason, flag_attrs(PHASE_FLAGS))}
