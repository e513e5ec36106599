"""Is a run's answer settled?  The in-run check behind ``run.until``.

The sweep runner calls :func:`assess_trajectory` at its check steps on the frames it has
committed so far (its partial trajectory), with the analysis settings ``fcsweep analyze``
would use, so a run stops exactly when the analysis of its final trajectory would give
the labels at the required confidence.  The verdict is a pure function of the stored
frames: a run killed and resumed reaches the same verdict at the same step.

This module imports the analysis pipeline and nothing of the sweep runner.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from fcsweep.analysis.phase import PERCOLATION_UNDETERMINED, PHASE_UNDETERMINED, PHASE_UNKNOWN
from fcsweep.analysis.pipeline import AnalysisError, compute_observables, settings_with
from fcsweep.analysis.trajectory import TrajectoryError, open_trajectory

__all__ = ["Verdict", "judge", "assess_trajectory"]


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
    """Compare the scalars of :func:`fcsweep.analysis.pipeline.compute_observables` with
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


def assess_trajectory(path, *, transient: float, confidence: float,
                      rel_error: Mapping[str, float] | None = None, threads: int | None = None,
                      settings: Mapping | None = None) -> Verdict:
    """Analyse the frames of one (possibly partial) trajectory and :func:`judge` them.

    Parameters
    ----------
    path : path-like
        A trajectory in the contract layout; every frame in it is used.
    transient : float
        ``run.transient`` (the analysis setting ``fcsweep analyze`` uses for the sweep).
    confidence, rel_error
        See :func:`judge`.
    threads : int, optional
        freud threads for the Voronoi and order analysis (default: freud's setting).
    settings : mapping, optional
        Analysis settings beyond the defaults (the config's ``analysis`` section:
        ``label_confidence``, ``percolation_threshold``), so that the check labels as
        ``fcsweep analyze`` will.

    Returns
    -------
    Verdict
        Not settled, with the reason, when the frames cannot be analysed yet (too few
        after the transient, say).
    """
    if threads is not None:
        import freud

        freud.parallel.set_num_threads(int(threads))
    try:
        scalars, _, _ = compute_observables(open_trajectory(path), settings_with(settings, transient=transient),
                                            curves=False, psi6="psi6" in (rel_error or {}))
    except (AnalysisError, TrajectoryError) as exc:
        return Verdict(False, (f"not analysable yet: {exc}",))
    return judge(scalars, confidence=confidence, rel_error=rel_error)
