"""The analysis settings, declared once: how a run's frames become observables and labels.

:class:`AnalysisSettings` is the one typed table of them: every field has its default, its
allowed values and one line saying what it does (:data:`SETTINGS`, the rows), and every
value is checked by :func:`setting_problem` when an instance is made.  The sweep config's
``analysis`` section sets :data:`CONFIG_KEYS` (``run.transient`` sets ``transient``), the
Python API (:func:`fcsweep.observables`) takes any of them as keywords, and the results layer
(``fcsweep analyze``) stores :meth:`AnalysisSettings.as_dict` beside the observables.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any, Mapping

__all__ = ["AnalysisSettings", "Setting", "SETTINGS", "CONFIG_KEYS", "LABEL_CONFIDENCE", "PERCOLATION_THRESHOLD",
           "DEFAULT_TRANSIENT", "CORRELATIONS", "DEFAULT_CORRELATIONS", "Q_RANGE", "Q_BINS", "setting_problem"]

#: Default probability a phase, percolation or KTHNY label needs (else it is undetermined).
LABEL_CONFIDENCE = 0.95
#: Default defect fraction rho_d above which a run or point is percolated (the paper's 1/2).
PERCOLATION_THRESHOLD = 0.5
#: Default fraction of the recorded frames discarded at the start of every analysis.
DEFAULT_TRANSIENT = 0.2
#: How G6, C_G1 and G_r are computed: ``pairs`` (pair counts, O(N^2) per frame; the
#: reference), ``fft`` (on a grid by FFT, O(N log N)) or ``auto`` (pairs up to 10^4 cells,
#: FFT above: :func:`fcsweep.config.settings.correlation_method`).
CORRELATIONS = ("auto", "pairs", "fft")
#: Default ``correlations``; at it the key is left out of stored settings.
DEFAULT_CORRELATIONS = "auto"
#: Range of the shape-index histogram and its number of bins (edges every 0.01).
Q_RANGE, Q_BINS = (3.54, 5.04), 150

#: The keys a sweep config's ``analysis`` section sets.
CONFIG_KEYS = ("label_confidence", "percolation_threshold", "correlations")


@dataclass(frozen=True)
class Setting:
    """One row of the table: name, type, default, the allowed values in words and as a
    test, and what it does."""

    name: str
    type: type
    default: Any
    allowed: str
    test: Any
    doc: str


def _row(default, allowed: str, test, doc: str):
    return field(default=default, metadata={"allowed": allowed, "test": test, "doc": doc})


def _number(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def _count(lo: int):
    return lambda x: isinstance(x, int) and not isinstance(x, bool) and x >= lo


@dataclass(frozen=True)
class AnalysisSettings:
    """The analysis settings (module docstring); made with keywords, each value checked.

    Raises
    ------
    ValueError
        Naming the setting, the value and what is allowed.
    """

    transient: float = _row(DEFAULT_TRANSIENT, "0 <= transient < 1", lambda x: _number(x) and 0 <= x < 1,
                            "fraction of the recorded frames discarded at the start (run.transient)")
    fit_start: float = _row(0.2, "0 <= fit_start < 1", lambda x: _number(x) and 0 <= x < 1,
                            "fraction of the MSD's lag range left out before the D_eff fit")
    max_time_blocks: int = _row(8, "an integer >= 2", _count(2),
                                "most time blocks of the correlated errors (each at least min_block_persistence / Dr)")
    min_block_persistence: float = _row(8.0, "> 0", lambda x: _number(x) and x > 0,
                                        "shortest time block, in persistence times 1/Dr")
    label_confidence: float = _row(LABEL_CONFIDENCE, "0.5 < label_confidence < 1",
                                   lambda x: _number(x) and 0.5 < x < 1, "the probability a label needs")
    percolation_threshold: float = _row(PERCOLATION_THRESHOLD, "0 < percolation_threshold < 1",
                                        lambda x: _number(x) and 0 < x < 1,
                                        "defect fraction rho_d")
    subtract_drift: bool = _row(True, "true or false", lambda x: isinstance(x, bool),
                                "remove the centre-of-mass motion before the MSD")
    msd_lags: int = _row(120, "an integer >= 4", _count(4), "lags of the MSD (log-spaced)")
    shape_frames: int = _row(200, "an integer >= 1", _count(1), "frames at most for <q> and its histogram")
    structure_frames: int = _row(100, "an integer >= 1", _count(1),
                                 "frames at most for the Voronoi defects, clusters and Psi6")
    correlation_frames: int = _row(10, "an integer >= 1", _count(1), "frames at most for G6, C_G1 and G_r")
    q_edges: tuple = _row((Q_RANGE[0], Q_RANGE[1], Q_BINS), "(low, high, bins) with low < high, bins >= 1",
                          lambda x: (isinstance(x, (tuple, list)) and len(x) == 3 and _number(x[0])
                                     and _number(x[1]) and x[0] < x[1] and _count(1)(x[2])),
                          "shape-index histogram: lowest and highest edge and the number of bins")
    q_points: int = _row(1024, "an integer >= 8", _count(8), "contour points per cell for the shape index")
    g6_dr: float = _row(0.1, "> 0", lambda x: _number(x) and x > 0, "bin width of G6 (R0)")
    gr_dx: float = _row(0.2, "> 0", lambda x: _number(x) and x > 0, "bin width of the G_r cut (R0)")
    correlations: str = _row(DEFAULT_CORRELATIONS, ", ".join(CORRELATIONS), lambda x: x in CORRELATIONS,
                             "auto: pair counts up to 10^4 cells, FFT above; pairs: pair counts, O(N^2); "
                             "fft: by FFT on a grid")

    def __post_init__(self):
        if isinstance(self.q_edges, list):
            object.__setattr__(self, "q_edges", tuple(self.q_edges))
        for f in dataclasses.fields(self):
            problem = setting_problem(f.name, getattr(self, f.name))
            if problem:
                raise ValueError(problem)

    @classmethod
    def from_dict(cls, values: Mapping) -> "AnalysisSettings":
        """The settings ``values`` names, the rest at their defaults; unknown names refused."""
        unknown = sorted(set(values) - set(SETTINGS))
        if unknown:
            raise ValueError(f"unknown analysis setting(s) {unknown}; allowed: {sorted(SETTINGS)}")
        values = dict(values)
        if "q_edges" in values:
            values["q_edges"] = tuple(values["q_edges"])
        return cls(**values)

    def replace(self, **values) -> "AnalysisSettings":
        """A copy with ``values`` changed (checked)."""
        return self.from_dict({**self.as_dict(every=True), **values})

    def as_dict(self, every: bool = False) -> dict[str, Any]:
        """The settings as the analysis reads and stores them: JSON types (``q_edges`` a
        list), ``correlations`` left out at its default unless ``every``."""
        out = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        out["q_edges"] = [float(out["q_edges"][0]), float(out["q_edges"][1]), int(out["q_edges"][2])]
        if not every and out["correlations"] == DEFAULT_CORRELATIONS:
            del out["correlations"]
        return out

    def config_dict(self) -> dict[str, Any]:
        """The keys a sweep config's ``analysis`` section sets (:data:`CONFIG_KEYS`),
        ``correlations`` left out at its default: what a config stores of them."""
        return {k: v for k, v in self.as_dict().items() if k in CONFIG_KEYS}


#: The rows of the table, by name.
SETTINGS: dict[str, Setting] = {
    f.name: Setting(f.name, f.type, f.default, f.metadata["allowed"], f.metadata["test"], f.metadata["doc"])
    for f in dataclasses.fields(AnalysisSettings)}


def setting_problem(name: str, value, key: str | None = None) -> str:
    """Why ``value`` cannot be analysis setting ``name`` ("" if it can); ``key`` is how the
    message names it (``analysis.label_confidence`` in a config)."""
    row = SETTINGS[name]
    if row.test(value):
        return ""
    if name in ("correlations", "subtract_drift"):
        return f"{key or name} = {value!r} is not allowed; allowed: {row.allowed} ({row.doc})"
    return f"{key or name} = {value!r} is out of range; allowed {row.allowed} ({row.doc})"
