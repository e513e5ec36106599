"""The measured systematic errors of the contour rules and step sizes, declared once.

A run made with the ``binary`` or ``linear`` contour rule, or with a step ``dt`` above the
converged 0.005, measures ``<q>`` and the diffusion a little off the converged model (the
``arc`` rule at K = 40, dt = 0.005, which agrees with K = 80 and dt = 0.0025 within the
replicate noise).  :func:`rule_bias` gives the range of that offset for a run's settings,
from the paired measurements of docs/speed_vs_error.md (a fluid state at ``<q>`` = 3.73,
N = 144, 8 seeds) and the binary-against-arc cut of the paper campaign (v0 = 0.06,
eta = 0.02-0.06, N = 1024, ``<q>`` 3.81-3.86: binary reads 0.025-0.073 higher):

=====================================  ======================  ==========================
setting                                <q> offset              relative offset of D
=====================================  ======================  ==========================
arc, any K >= 24, dt <= 0.005          0                       0
binary, K >= 80, dt <= 0.005           0 .. +0.005             -0.04 .. +0.04
binary, K < 80, dt <= 0.005            +0.022 .. +0.073        -0.04 .. +0.04
linear, dt <= 0.005                    +0.093 .. +0.105        0 .. +0.13
dt in (0.005, 0.01]                    adds 0 .. +0.010        adds -0.17 .. 0
dt in (0.01, 0.02]                     adds +0.010 .. +0.037   adds -0.52 .. 0
dt above 0.02                          not measured (inf)      not measured (inf)
=====================================  ======================  ==========================

The linear rule's offset was measured in the one fluid state only.  The phase rule
(:func:`fcsweep.analysis.phase.phase_label`) reads these ranges from each run's scalars
(``q_bias_low``, ``q_bias_high``, ``d_bias_low``, ``d_bias_high``; NaN, as in analyses made
before they existed, reads as no offset): a label whose deciding
estimate, corrected by any offset in the range, would fall on the other side of its
threshold is undetermined with reason code ``rule_sensitive``.
"""

from __future__ import annotations

__all__ = ["CONVERGED_DT", "rule_bias"]

#: The step up to which the offsets of the contour rules were measured.
CONVERGED_DT = 0.005


def rule_bias(quadrature: str, contour_points: int, dt: float, modes: int = 6) -> dict[str, float]:
    """The measured range of a run's systematic offsets (module docstring).

    Returns
    -------
    dict
        ``q_bias_low``, ``q_bias_high`` (added to the converged ``<q>``) and ``d_bias_low``,
        ``d_bias_high`` (relative: D measured = D converged (1 + offset)); -inf .. +inf where
        not measured (dt above 0.02): no label is then decided.
    """
    inf = float("inf")
    if int(modes) == 0:  # rigid discs: the exact lens overlap, no contour rule
        q, d = (0.0, 0.0), (0.0, 0.0)
    elif quadrature == "arc":
        q, d = (0.0, 0.0), (0.0, 0.0)
    elif quadrature == "binary":
        q = (0.0, 0.005) if int(contour_points) >= 80 else (0.022, 0.073)
        d = (-0.04, 0.04)
    else:  # linear
        q, d = (0.093, 0.105), (0.0, 0.13)
    dt = float(dt)
    if dt > 0.02 * (1 + 1e-9):
        return {"q_bias_low": -inf, "q_bias_high": inf, "d_bias_low": -inf, "d_bias_high": inf}
    if dt > 0.01 * (1 + 1e-9):
        q, d = (q[0] + 0.010, q[1] + 0.037), (d[0] - 0.52, d[1])
    elif dt > CONVERGED_DT * (1 + 1e-9):
        q, d = (q[0], q[1] + 0.010), (d[0] - 0.17, d[1])
    return {"q_bias_low": q[0], "q_bias_high": q[1], "d_bias_low": d[0], "d_bias_high": d[1]}
