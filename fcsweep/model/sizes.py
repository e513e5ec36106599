"""Cell size differences: per-cell radii R0,i drawn from the run's seed (pure numpy).

The parameter ``R0`` stays the length unit and is the *mean* radius; each cell keeps the
area pi R0,i^2 of its own radius (its shape modes are relative to R0,i, docs/model.md).
The distributions (``size_distribution``):

* ``monodisperse`` (default): every R0,i = R0; nothing is drawn.
* ``bidisperse``: round(``size_fraction`` N) small cells of radius r_s and the rest large,
  r_l = ``size_ratio`` r_s, assigned to cells by a random permutation;
* ``lognormal``: ln R0,i normal with sigma = sqrt(ln(1 + w^2)) (relative width w =
  ``size_width``), truncated to within 2 sigma of the median (redrawn beyond);
* ``gaussian``: R0,i normal with relative width w, truncated to 1 -+ 2w (redrawn beyond).

All are then scaled so that their mean is exactly R0.  The draws come from a stream of
their own, ``PCG64(SeedSequence([seed, SIZE_STREAM]))``: the dynamics' noise stream
``PCG64(seed)`` and the disordered start's stream are untouched, so a monodisperse run is
the run it was before sizes existed.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["SIZE_DISTRIBUTIONS", "SIZE_STREAM", "TRUNCATION", "cell_radii", "radius_bounds", "effective_radius",
           "size_problem"]

#: The size distributions (the ``size_distribution`` parameter).
SIZE_DISTRIBUTIONS = ("monodisperse", "bidisperse", "lognormal", "gaussian")
#: Second word of the seed sequence of the sizes' own stream (ASCII "size").
SIZE_STREAM = 0x73697A65
#: Truncation of the continuous distributions, in their widths.
TRUNCATION = 2.0


def _unit_bounds(distribution: str, ratio: float, fraction: float, width: float) -> tuple[float, float]:
    """Smallest and largest radius before the scaling to the mean (median / small = 1)."""
    if distribution == "bidisperse":
        return (1.0, ratio) if 0.0 < fraction < 1.0 else ((1.0, 1.0) if fraction >= 1.0 else (ratio, ratio))
    if distribution == "lognormal":
        s = math.sqrt(math.log1p(width * width))
        return math.exp(-TRUNCATION * s), math.exp(TRUNCATION * s)
    if distribution == "gaussian":
        return 1.0 - TRUNCATION * width, 1.0 + TRUNCATION * width
    return 1.0, 1.0


def radius_bounds(distribution: str, ratio: float = 1.4, fraction: float = 0.5, width: float = 0.1,
                  R0: float = 1.0) -> tuple[float, float]:
    """Bounds (R_min, R_max) every draw of :func:`cell_radii` respects, for checks made
    before the radii exist (time step, contour spacing).

    Bidisperse radii are exact; for the continuous ones the mean of the draw lies between
    the truncation bounds lo, hi, so R_i / R0 lies in [lo / hi, hi / lo].
    """
    lo, hi = _unit_bounds(distribution, ratio, fraction, width)
    if distribution == "bidisperse":
        f = fraction
        mean = f * lo + (1.0 - f) * hi if 0.0 < f < 1.0 else lo
        return R0 * lo / mean, R0 * hi / mean
    if distribution in ("lognormal", "gaussian"):
        return R0 * lo / hi, R0 * hi / lo
    return R0, R0


def cell_radii(N: int, seed: int, distribution: str = "monodisperse", ratio: float = 1.4, fraction: float = 0.5,
               width: float = 0.1, R0: float = 1.0):
    """The per-cell radii R0,i of a run, or ``None`` for ``monodisperse`` (nothing drawn).

    Parameters
    ----------
    N : int
        Number of cells.
    seed : int
        The run's seed; the radii come from ``PCG64(SeedSequence([seed, SIZE_STREAM]))``.
    distribution : {"monodisperse", "bidisperse", "lognormal", "gaussian"}
    ratio : float
        Bidisperse: large / small radius.
    fraction : float
        Bidisperse: fraction of small cells.
    width : float
        Lognormal, Gaussian: relative width w.
    R0 : float
        The mean radius.

    Returns
    -------
    ndarray, shape (N,), or None
        Radii with mean R0 (to round-off).
    """
    if distribution == "monodisperse":
        return None
    if distribution not in SIZE_DISTRIBUTIONS:
        raise ValueError(f"size_distribution must be one of {list(SIZE_DISTRIBUTIONS)}; got {distribution!r}")
    rng = np.random.Generator(np.random.PCG64(np.random.SeedSequence([int(seed), SIZE_STREAM])))
    N = int(N)
    lo, hi = _unit_bounds(distribution, ratio, fraction, width)
    if distribution == "bidisperse":
        small = int(round(fraction * N))
        r = np.where(np.arange(N) < small, 1.0, float(ratio))
        r = r[rng.permutation(N)]
    else:
        r = np.empty(N)
        todo = np.arange(N)
        while todo.size:
            if distribution == "lognormal":
                x = np.exp(rng.normal(0.0, math.sqrt(math.log1p(width * width)), todo.size))
            else:
                x = rng.normal(1.0, width, todo.size)
            r[todo] = x
            todo = todo[(x < lo) | (x > hi)]
    return r * (R0 / r.mean())


def effective_radius(radii, R0: float = 1.0) -> float:
    """sqrt(<R0,i^2>): the radius whose N discs cover the same area as the cells, which sets
    the box at the area fraction (N pi R_eff^2 / (Lx Ly) = density); R0 without radii."""
    if radii is None:
        return R0
    return float(np.sqrt(np.mean(np.asarray(radii, float) ** 2)))


def size_problem(distribution: str, initial: str, integrator: str, width: float = 0.1,
                 adhesion: float = 0.0) -> str:
    """Why a size distribution cannot run with these settings ("" if it can).

    Unequal cells on the hexagonal lattice overlap badly, so size-disperse runs start
    ``disordered``; the contact integrators' per-contact factors assume one radius, and so
    does the adhesion term (:mod:`fcsweep.model.adhesion`, one R0).
    """
    if distribution == "monodisperse":
        return ""
    if adhesion > 0.0:
        return (f"size_distribution = {distribution!r} cannot be combined with adhesion > 0 (the adhesion term "
                f"assumes one radius R0); got adhesion = {adhesion!r}")
    if initial != "disordered":
        return (f"size_distribution = {distribution!r} needs initial: disordered (unequal cells on the hexagonal "
                f"lattice overlap badly); got initial = {initial!r}")
    if integrator != "euler":
        return f"size_distribution = {distribution!r} needs integrator 'euler'; got {integrator!r}"
    if distribution in ("lognormal", "gaussian") and width <= 0.0:
        return f"size_distribution = {distribution!r} needs size_width > 0"
    return ""
