"""Crystalline cells, the crystal fraction of a run and the ``phase_coexistence`` label of a
coexistence start (``initial: coexistence``, docs/model.md).

**Which cells are crystalline** (:func:`crystalline`). Cell ``i`` is crystalline when it has
six Voronoi neighbours and its bond order agrees with each of theirs:
``Re(psi6_i psi6_j^*) >= CRYSTAL_COHERENCE = 1/2`` for all six neighbours ``j``
(``psi6`` of :func:`fcsweep.analysis.order.psi6`). Since ``|psi6| <= 1`` this asks each of
the seven cells for ``|psi6| >= 1/2`` and for local orientations within
``arccos(1/2) / 6 = 10`` degrees of each other: a cell of a crystallite, not a single
six-sided cell of a dense fluid (70 % of a fluid's cells have six sides). Measured at
N = 1024, ρ = 0.95, quadrature binary, D_r = 0.01 (seed 1):

- the lattice start: 1.000; a lattice run at η = 0.1, v0 = 0.01 after 50 time units: 1.000;
- the coexistence start: 0.516 (the slab's rows 1.00, the two interface rows 0.5-0.6, the
  disordered band 0.06-0.27 at η = 0.1);
- the disordered start (a quenched packing, not a fluid): 0.18 at η = 0.1, 0.06 at η = 0.03;
- a flowing fluid (η = 0.03, v0 = 0.06, 50-100 time units from the lattice or the
  disordered start): 0.000-0.004.

Looser rules count too much of a disordered packing: six sides with ``|psi6_i| >= 0.7``
gives 0.65 on the disordered start at η = 0.1; five coherent neighbours of six, 0.29.

**The crystal fraction** ``f(t)`` is the fraction of crystalline cells in each frame
(:func:`crystal_fraction`); :func:`crystal_trend` gives its mean and its slope (least
squares in time) with errors for correlated frames: the mean's from
:func:`fcsweep.analysis.stats.time_average`, the slope's ``sqrt(var(r) tau_r / S_tt)`` with
``r`` the residuals about the line, ``S_tt = sum (t - tbar)^2`` and ``tau_r`` their
integrated autocorrelation time by Sokal's window as in :mod:`fcsweep.analysis.stats`
(window constant :data:`~fcsweep.analysis.stats.C_WINDOW`). A fitted line takes more of the
residuals' slow fluctuations than a fitted mean, so the windowed sum is divided by
``1 - 4M/n`` (window ``M``; at most 4x) where the mean's estimator divides by ``1 - 2M/n``:
on AR(1) series of 101-801 frames with ``n / tau`` = 18-42 the slope errors then match the
scatter of the slopes to 0.85-0.99 (``1 - 2M/n``: 0.71-0.88; tests/test_coexistence.py), so a
label needs :data:`MIN_SLOPE_SAMPLES` effective samples.

**The label** (:func:`phase_coexistence`). The slab has two flat interfaces across a box of
height ``Ly``, so the speed at which each advances is ``v = (Ly / 2) df/dt``. The crystal
that grows (``v > 0``) is the stable phase; at a point where the solid is not stable the
fluid in contact melts it (``v < 0``). A speed is decided against
``v* = 4 D_s / h`` (:func:`solid_speed`): the speed of an interface that moves one row
spacing ``h = Ly / n`` in the time a cell diffusing at the solid threshold ``D_s = 1e-3``
(:data:`fcsweep.analysis.diffusion.D_EFF_SOLID`) takes to cover it (``h^2 = 4 D_s t``).
Cells that rearrange slower than that are solid by the MSD rule, so a crystal receding
slower is not told from a solid's creep (v* = 2.4·10⁻³ R0/τ at ρ = 0.95: 0.044 of f in
500 time units at N = 1024). With ``v`` Gaussian about its estimate:

- *not solid* if the crystal is gone: the mean of ``f`` over the last quarter of the frames
  is below :data:`FLUID_LEVEL` with probability ``>= min_confidence``;
- *solid* if the crystal has filled the box: that mean is above :data:`FILLED_LEVEL`
  (midway between the start's 1/2 and a perfect crystal) with that probability. Both end
  states hold no interface, so they are read first; a crystal grown at η = 0.1,
  v0 = 0.01 levels off at 0.89 (grain boundaries) after 300 time units, where a straight
  line through the whole run no longer describes ``f``;
- otherwise both interfaces are still there and ``v`` is read from the slope after the
  settling time: *not solid* if ``P(v < -v*) >= min_confidence`` (the crystal melts),
  *solid* if ``P(v > -v*) >= min_confidence`` (the reason says whether it grows,
  ``P(v > 0) >= min_confidence``, or stays);
- otherwise *undetermined* with the reason (too few frames or effective samples, or ``v``
  within its error of ``-v*``: a longer run decides).

``min_confidence`` defaults to :data:`fcsweep.analysis.phase.MIN_CONFIDENCE`.
The first :data:`SETTLE_TIME` time units are left out of the slope: the interfaces of the
relaxed start roughen there once the cells move (measured in docs/model.md, "Coexistence
start").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fcsweep.analysis.diffusion import D_EFF_SOLID
from fcsweep.analysis.order import psi6
from fcsweep.analysis.phase import MIN_CONFIDENCE, p_above
from fcsweep.analysis.stats import time_average, windowed_time
from fcsweep.analysis.voronoi import voronoi_neighbors

__all__ = ["CRYSTAL_COHERENCE", "FLUID_LEVEL", "FILLED_LEVEL", "SETTLE_TIME", "MIN_FRAMES", "MIN_END_FRAMES",
           "MIN_SLOPE_SAMPLES",
           "COEXISTENCE_UNKNOWN", "COEXISTENCE_SOLID", "COEXISTENCE_NOT_SOLID", "COEXISTENCE_UNDETERMINED",
           "COEXISTENCE_FLAGS", "COEXISTENCE_REASONS", "CrystalTrend", "CoexistenceLabel", "crystalline",
           "crystal_fraction", "crystal_trend", "solid_speed", "phase_coexistence", "COEXISTENCE_SCALARS",
           "coexistence_observables"]

#: Smallest ``Re(psi6_i psi6_j^*)`` a crystalline cell has with each of its six neighbours.
CRYSTAL_COHERENCE = 0.5
#: Crystal fraction below which the crystal is gone (flowing fluids hold 0.000-0.004).
FLUID_LEVEL = 0.05
#: Crystal fraction above which the crystal has filled the box (the start holds 1/2).
FILLED_LEVEL = 0.75
#: Time units after the start left out of the slope (the interfaces' roughening).
SETTLE_TIME = 20.0
#: Fewest frames (after :data:`SETTLE_TIME`) the interface speed is read from (fewer give no
#: trustworthy autocorrelation time); an end state (melted, filled) is read from 8.
MIN_FRAMES = 20
#: Fewest frames (after :data:`SETTLE_TIME`) an end state is read from (a last quarter of 2-4).
MIN_END_FRAMES = 8
#: Fewest effectively independent residuals (``n / tau``, tau as estimated) the slope's error
#: is trusted on (AR(1) with true ``n / tau`` = 11: errors 0.86 of the scatter; 5: 0.66).
MIN_SLOPE_SAMPLES = 10.0

COEXISTENCE_UNKNOWN, COEXISTENCE_SOLID, COEXISTENCE_NOT_SOLID, COEXISTENCE_UNDETERMINED = -1, 0, 1, 2
#: Codes and CF ``flag_meanings`` of ``phase_coexistence``.
COEXISTENCE_FLAGS = {COEXISTENCE_UNKNOWN: "unknown", COEXISTENCE_SOLID: "solid",
                     COEXISTENCE_NOT_SOLID: "not_solid", COEXISTENCE_UNDETERMINED: "undetermined"}
#: Reason codes of ``phase_coexistence``: name -> meaning.
COEXISTENCE_REASONS = {
    "not_coexistence": "the run did not start from a coexistence start",
    "too_few_frames": f"fewer than {MIN_END_FRAMES} frames after the settling time (no end state: {MIN_FRAMES})",
    "no_error": f"fewer than {MIN_SLOPE_SAMPLES:g} effective samples for the slope's error",
    "crystal_grows": "the crystal grows: solid is stable",
    "crystal_stays": "the crystal recedes slower than v*: solid",
    "crystal_melts": "the crystal recedes faster than v*: not solid",
    "crystal_melted": "the crystal fraction fell to the fluid's level: not solid",
    "crystal_filled": "the crystal fraction rose to the filled level: solid",
    "near_v_threshold": "the interface speed is within its error of -v*: a longer run decides",
}


def crystalline(pos: np.ndarray, box, radii=None, vn=None) -> np.ndarray:
    """Crystalline cells of one frame (module docstring: six Voronoi neighbours, each with
    ``Re(psi6_i psi6_j^*) >= CRYSTAL_COHERENCE``).

    Parameters
    ----------
    pos : ndarray, shape (N, 2)
        Centres in the periodic box.
    box : (Lx, Ly)
    radii : ndarray, shape (N,), optional
        Per-cell radii (the radical tessellation, :func:`fcsweep.analysis.voronoi.voronoi_neighbors`).
    vn : fcsweep.analysis.voronoi.VoronoiNeighbors, optional
        The frame's tessellation, when the caller has it (else computed).

    Returns
    -------
    ndarray of bool, shape (N,)
    """
    if vn is None:
        vn = voronoi_neighbors(pos, box, radii)
    ps = psi6(pos, box, vn.nlist)
    N = len(ps)
    coherent = np.real(ps[vn.i] * np.conj(ps[vn.j])) >= CRYSTAL_COHERENCE
    agree = np.bincount(vn.i, weights=coherent.astype(float), minlength=N)
    return (vn.n_sides == 6) & (agree == 6)


def crystal_fraction(frames, box, radii=None) -> np.ndarray:
    """Fraction of crystalline cells in each frame.

    Parameters
    ----------
    frames : iterable of ndarray, shape (N, 2)
        Centres of each frame (an array ``(T, N, 2)`` or a
        :class:`fcsweep.analysis.frames.FrameSource`; unwrapped centres are wrapped).
    box : (Lx, Ly)
    radii : ndarray, optional
        Per-cell radii.

    Returns
    -------
    ndarray, shape (T,)
    """
    L = np.asarray(box, dtype=float)
    return np.array([crystalline(np.mod(np.asarray(p, dtype=float), L), L, radii).mean()
                     for p in (frames[k] for k in range(len(frames)))])


@dataclass(frozen=True)
class CrystalTrend:
    """Mean and slope of a crystal-fraction series with errors for correlated frames.

    Attributes
    ----------
    mean, mean_err : float
        Time average and its error (:func:`fcsweep.analysis.stats.time_average`, no cut).
    slope, slope_err : float
        Least-squares ``df/dt`` (per time unit) and its error (module docstring).
    tau : float
        Integrated autocorrelation time of the residuals, in frames.
    n_eff : float
        Effectively independent residuals, ``n / tau``.
    n : int
        Frames used.
    """

    mean: float
    mean_err: float
    slope: float
    slope_err: float
    tau: float
    n_eff: float
    n: int


def crystal_trend(t, f) -> CrystalTrend:
    """Mean and slope of ``f`` against ``t`` with their correlated errors.

    Parameters
    ----------
    t, f : array_like, shape (n,)
        Times (equally spaced) and crystal fractions; finite.

    Returns
    -------
    CrystalTrend
        Errors NaN with fewer than 4 frames.
    """
    t = np.asarray(t, dtype=float).ravel()
    f = np.asarray(f, dtype=float).ravel()
    if t.shape != f.shape:
        raise ValueError(f"crystal_trend: t and f differ in length ({t.size} and {f.size})")
    nan = float("nan")
    n = f.size
    if n < 4:
        mean = float(f.mean()) if n else nan
        return CrystalTrend(mean, nan, nan, nan, nan, float(n), n)
    avg = time_average(f, equilibrate=False)
    dt = t - t.mean()
    stt = float(np.sum(dt * dt))
    slope = float(np.sum(dt * (f - f.mean())) / stt)
    resid = f - f.mean() - slope * dt
    var = float(np.sum(resid ** 2) / (n - 2))
    tau = _line_residual_time(resid) if var > 0 else 1.0
    err = float(np.sqrt(var * tau / stt))
    return CrystalTrend(avg.mean, avg.err, slope, err, float(tau), float(n / tau), n)


def _line_residual_time(r: np.ndarray) -> float:
    """Integrated autocorrelation time of residuals about a fitted line (module docstring)."""
    tau, M = windowed_time(r)
    return float(min(max(tau / max(1.0 - 4.0 * M / r.size, 0.25), 1.0), r.size))


def solid_speed(height: float, n_rows: int, d_solid: float = D_EFF_SOLID) -> float:
    """``v* = 4 D_s / h``, ``h = height / n_rows`` the lattice's row spacing (R0 per time unit)."""
    return 4.0 * d_solid * n_rows / float(height)


@dataclass(frozen=True)
class CoexistenceLabel:
    """The ``phase_coexistence`` label.

    Attributes
    ----------
    code : int
        A key of :data:`COEXISTENCE_FLAGS`.
    confidence : float
        Probability of the label decided (of the more probable side when undetermined).
    reason : str
        What decided, with the numbers.
    reason_code : str
        A key of :data:`COEXISTENCE_REASONS`.
    speed, speed_err : float
        Interface speed ``(Ly / 2) df/dt`` (R0 per time unit) and its error.
    """

    code: int
    confidence: float
    reason: str
    reason_code: str
    speed: float = float("nan")
    speed_err: float = float("nan")

    def __post_init__(self):
        if self.reason_code not in COEXISTENCE_REASONS:
            raise ValueError(f"undeclared reason code {self.reason_code!r}")


def phase_coexistence(t, f, box, N: int, *, min_confidence: float = MIN_CONFIDENCE,
                      settle_time: float = SETTLE_TIME, d_solid: float = D_EFF_SOLID) -> CoexistenceLabel:
    """Decide solid / not solid from the crystal fraction of a coexistence run.

    Parameters
    ----------
    t : array_like, shape (n,)
        Times of the frames (time units; equally spaced), the start at ``t[0]``.
    f : array_like, shape (n,)
        Crystal fraction of each frame (:func:`crystal_fraction`).
    box : (Lx, Ly)
        The periodic box; the interfaces lie along x.
    N : int
        Number of cells, ``n*n`` (``n`` rows of spacing ``Ly / n``).
    min_confidence : float
        Probability a decided label needs.
    settle_time : float
        Time after ``t[0]`` left out of the slope.
    d_solid : float
        Solid threshold of D_eff, which sets ``v*`` (:func:`solid_speed`).

    Returns
    -------
    CoexistenceLabel
    """
    t = np.asarray(t, dtype=float).ravel()
    f = np.asarray(f, dtype=float).ravel()
    height = float(np.asarray(box, dtype=float)[1])
    n_rows = int(round(np.sqrt(N)))
    v_star = solid_speed(height, n_rows, d_solid)
    keep = t >= t[0] + settle_time if t.size else np.zeros(0, bool)
    tk, fk = t[keep], f[keep]
    if tk.size < MIN_END_FRAMES:
        return CoexistenceLabel(COEXISTENCE_UNDETERMINED, float("nan"),
                                f"{tk.size} frames after the first {settle_time:g} time units; "
                                f"{MIN_END_FRAMES} needed", "too_few_frames")
    last = time_average(fk[-max(4, fk.size // 4):], equilibrate=False)
    p_gone = p_above(FLUID_LEVEL, last.err, last.mean)
    end = f"crystal fraction {last.mean:.3f} ± {last.err:.1g} over the last quarter"
    if p_gone >= min_confidence:
        return CoexistenceLabel(COEXISTENCE_NOT_SOLID, p_gone,
                                f"the crystal melted: {end}, below the fluid's level {FLUID_LEVEL:g}", "crystal_melted")
    p_filled = p_above(last.mean, last.err, FILLED_LEVEL)
    if p_filled >= min_confidence:
        return CoexistenceLabel(COEXISTENCE_SOLID, p_filled,
                                f"solid: the crystal filled the box: {end}, above {FILLED_LEVEL:g}", "crystal_filled")
    if tk.size < MIN_FRAMES:
        return CoexistenceLabel(COEXISTENCE_UNDETERMINED, float("nan"),
                                f"{end}: no end state, and {tk.size} frames after the first {settle_time:g} time "
                                f"units for the interface speed; {MIN_FRAMES} needed", "too_few_frames")
    trend = crystal_trend(tk, fk)
    v, v_err = trend.slope * height / 2.0, trend.slope_err * height / 2.0
    if not (np.isfinite(v_err) and trend.n_eff >= MIN_SLOPE_SAMPLES):
        return CoexistenceLabel(COEXISTENCE_UNDETERMINED, float("nan"),
                                f"{trend.n_eff:.1f} effective samples of the slope ({MIN_SLOPE_SAMPLES:g} "
                                "needed): a longer run decides", "no_error", v, v_err)
    p_solid = p_above(v, v_err, -v_star)
    speed = f"interface speed v = {v:.2g} ± {v_err:.1g} R0/τ against v* = {v_star:.2g}"
    if p_solid >= min_confidence:
        p_grow = p_above(v, v_err, 0.0)
        grows = p_grow >= min_confidence
        return CoexistenceLabel(COEXISTENCE_SOLID, p_solid,
                                f"solid: the crystal {'grows' if grows else 'stays'} ({speed}, "
                                f"P(v > 0) = {p_grow:.3f})", "crystal_grows" if grows else "crystal_stays", v, v_err)
    if 1.0 - p_solid >= min_confidence:
        return CoexistenceLabel(COEXISTENCE_NOT_SOLID, 1.0 - p_solid, f"not solid: the crystal melts ({speed})",
                                "crystal_melts", v, v_err)
    return CoexistenceLabel(COEXISTENCE_UNDETERMINED, max(p_solid, 1.0 - p_solid),
                            f"{speed}: P(solid) = {p_solid:.3f}; a longer run decides", "near_v_threshold",
                            v, v_err)


#: The run scalars of :func:`coexistence_observables` (NaN unless the run started ``coexistence``).
COEXISTENCE_SCALARS = ("crystal_fraction", "crystal_fraction_err", "crystal_speed", "crystal_speed_err",
                       "phase_coexistence", "phase_coexistence_confidence")


def coexistence_observables(t, f, box, N: int, *, min_confidence: float = MIN_CONFIDENCE) -> dict:
    """The run scalars of a coexistence run from its analysed frames.

    Parameters
    ----------
    t : array_like, shape (n,)
        Times of the frames since the start (the first analysed frame may come after the
        transient: the settling time is then counted from the start, ``t = 0``).
    f : array_like, shape (n,)
        Crystal fraction of each frame.
    box, N, min_confidence
        As for :func:`phase_coexistence`.

    Returns
    -------
    dict
        :data:`COEXISTENCE_SCALARS`: the time average of ``f`` with its error
        (:func:`fcsweep.analysis.stats.time_average`, no cut), the interface speed the label
        read (NaN when an end state decided it) and the label's code and confidence.
    """
    t = np.asarray(t, dtype=float).ravel()
    f = np.asarray(f, dtype=float).ravel()
    avg = time_average(f, equilibrate=False)
    settle = max(0.0, SETTLE_TIME - float(t[0])) if t.size else SETTLE_TIME
    lab = phase_coexistence(t, f, box, N, min_confidence=min_confidence, settle_time=settle)
    return {"crystal_fraction": avg.mean, "crystal_fraction_err": avg.err, "crystal_speed": lab.speed,
            "crystal_speed_err": lab.speed_err, "phase_coexistence": float(lab.code),
            "phase_coexistence_confidence": lab.confidence}
