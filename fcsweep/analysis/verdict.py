"""Is a run's answer settled?  The verdict behind ``run.until``, from the scalars of a run.

:func:`judge` compares the scalars of :func:`fcsweep.analysis.run_observables.compute_observables`
with the targets of ``run.until`` (labels at a confidence, relative errors); the sweep runner
gets them from the frames it has committed so far (:func:`fcsweep.results.settle.assess_trajectory`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from fcsweep.analysis.phase import PERCOLATION_UNDETERMINED, PHASE_UNDETERMINED, PHASE_UNKNOWN

__all__ = ["Verdict", "judge"]


@dataclass(frozen=True)
class Verdict:
    """Outcome of one check.

    Attributes
    ----------
    settled : bool
        Every target met.
    unmet : tuple of str
        One line per target not met (empty when settled).
    values : dict
        The numbers the verdict was taken on (labels, confidences, relative errors).
    """

    settled: bool
    unmet: tuple[str, ...] = ()
    values: dict = field(default_factory=dict)


def judge(scalars: Mapping[str, float], *, confidence: float,
          rel_error: Mapping[str, float] | None = None) -> Verdict:
    """Compare the scalars of :func:`fcsweep.analysis.run_observables.compute_observables` with
    the targets of ``run.until``.

    Parameters
    ----------
    scalars : mapping
        Needs ``phase``, ``phase_confidence``, ``percolated``, ``percolated_confidence``
        and ``<name>``, ``<name>_err`` for every name of ``rel_error``.
    confidence : float
        Probability both labels must reach (they must also be determined).
    rel_error : mapping, optional
        Observable -> largest allowed ``err / |value|``.

    Returns
    -------
    Verdict
    """
    unmet = []
    values = {}
    for label, undetermined in (("phase", PHASE_UNDETERMINED), ("percolated", PERCOLATION_UNDETERMINED)):
        code = float(scalars[label])
        conf = float(scalars[f"{label}_confidence"])
        values[label], values[f"{label}_confidence"] = code, conf
        if not np.isfinite(code) or int(code) in (PHASE_UNKNOWN, undetermined):
            why = scalars.get(f"{label}_reason", "")
            unmet.append(f"{label} undetermined" + (f" ({why})" if why else ""))
        elif not conf >= confidence:  # NaN is not met
            unmet.append(f"{label} confidence {conf:.3f} < {confidence:g}")
    for name, target in (rel_error or {}).items():
        x, e = float(scalars[name]), float(scalars[f"{name}_err"])
        rel = abs(e / x) if x != 0 and np.isfinite(x) and np.isfinite(e) else float("inf")
        values[f"{name}_rel_error"] = rel
        if not rel <= target:
            unmet.append(f"{name} relative error {rel:.3g} > {target:g}")
    return Verdict(not unmet, tuple(unmet), values)
