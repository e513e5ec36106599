"""Is a run's answer settled?  The in-run check behind ``run.until``.

The sweep runner calls :func:`assess_trajectory` at its check steps on the frames it has
committed so far (its partial trajectory), with the analysis settings ``fcsweep analyze``
would use, so a run stops exactly when the analysis of its final trajectory would give
the labels at the required confidence.  The verdict (:func:`fcsweep.analysis.verdict.judge`)
is a pure function of the stored frames: a run killed and resumed reaches the same verdict
at the same step.

This module imports the analysis and nothing of the sweep runner.
"""

from __future__ import annotations

from typing import Mapping

from fcsweep.analysis.run_observables import AnalysisError
from fcsweep.analysis.verdict import Verdict, judge
from fcsweep.io.trajectory import TrajectoryError, open_trajectory
from fcsweep.results.analyze import settings_with, trajectory_observables

__all__ = ["Verdict", "judge", "assess_trajectory"]


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
        scalars, _, _ = trajectory_observables(open_trajectory(path), settings_with(settings, transient=transient),
                                               curves=False, psi6="psi6" in (rel_error or {}))
    except (AnalysisError, TrajectoryError) as exc:
        return Verdict(False, (f"not analysable yet: {exc}",))
    return judge(scalars, confidence=confidence, rel_error=rel_error)
