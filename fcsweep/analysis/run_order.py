"""The orientational order of one run, from its arrays: |Psi6|, G6, C_G1, G_r and the KTHNY
fits and label (the step of :func:`fcsweep.analysis.run_observables.compute_observables`
that the periodic runs take; a confined run gets :func:`not_periodic_kthny`).

The correlations come from the pair counts or, with ``settings["correlations"] == "fft"``,
by FFT on a grid (:func:`fcsweep.analysis.correlation_fft.pipeline_spacing`), averaged over
up to ``correlation_frames`` of the structure frames (:class:`OrderFrames` collects them
from the same Voronoi tessellations as the defects); :func:`frame_mean` gives a curve's
mean over frames with its frame-to-frame error.
"""

from __future__ import annotations

import warnings
from typing import Mapping

import numpy as np

from fcsweep.analysis import cage, correlation_fft, kthny, order, voronoi
from fcsweep.analysis.reasons import reason_value
from fcsweep.analysis.stats import time_average
from fcsweep.config.settings import DEFAULT_CORRELATIONS, correlation_method
from fcsweep.model.observables import KTHNY_FITS

#: What :func:`kthny_observables` gives: the fits, the label and its confidence.
KTHNY_SCALARS = KTHNY_FITS + ("kthny", "kthny_confidence", "kthny_reason_code")

__all__ = ["KTHNY_SCALARS", "OrderFrames", "evenly", "frame_mean", "kthny_observables", "not_periodic_kthny",
           "order_observables"]


def evenly(indices: np.ndarray, k: int) -> np.ndarray:
    """At most ``k`` evenly spaced entries of ``indices`` (always including the last)."""
    if k <= 0 or len(indices) <= k:
        return np.asarray(indices)
    pick = np.unique(np.round(np.linspace(0, len(indices) - 1, k)).astype(int))
    return np.asarray(indices)[pick]


def not_periodic_kthny() -> dict:
    """The KTHNY scalars of a confined run: not computed, reason code ``not_periodic``.

    G6(r), C_G1(r) and G_r are normalised for a homogeneous periodic system (pair counts
    against the ideal gas of the whole box, r up to half the box) and the KTHNY bounds
    (eta_G1 <= 1/3, eta_6 <= 1/4) are statements about their algebraic decay over many
    spacings; in a well or channel the walls order the cells next to them, the density is
    not uniform across, and the cells away from the walls span a few spacings only."""
    out = {k: np.nan for k in KTHNY_SCALARS}
    out["kthny_reason"] = ("not applicable: confined run (well or channel); the KTHNY correlations are those of a "
                           "homogeneous periodic system")
    out["kthny_reason_code"] = float(reason_value("not_periodic"))
    return out


def order_observables(pos: np.ndarray, boxr: np.ndarray, frames: np.ndarray, settings: Mapping, *,
                      curves: bool = True, psi6: bool = True):
    """|Psi6| on every structure frame; G6(r), G_r(dx, 0), C_G1(r) on up to
    ``correlation_frames`` of them, and the KTHNY fits and label (:func:`kthny_observables`).

    The correlations are the pair counts of :mod:`fcsweep.analysis.order`, or with
    ``settings["correlations"] == "fft"`` the same estimators on a grid
    (:func:`correlation_fft.correlations`, spacing :func:`correlation_fft.pipeline_spacing`);
    ``auto`` (or no key) is ``pairs`` up to 10^4 cells and ``fft`` above
    (:func:`fcsweep.config.settings.correlation_method`).
    :func:`compute_observables` feeds the same per-frame step the tessellations of the
    defect step instead of tessellating again.

    Returns
    -------
    scalars, curves : dict
    """
    acc = OrderFrames(pos.shape[1], boxr, frames, settings, curves)
    for f, P in zip(frames, pos) if (psi6 or curves) else ():  # G6 and G_r need Psi6 too
        acc.add(f, P, voronoi.voronoi_neighbors(P, boxr))
    return acc.finish()


class OrderFrames:
    """The per-frame part of :func:`order_observables` (:meth:`add` each frame's centres and
    tessellation) and its frame averages (:meth:`finish`)."""

    def __init__(self, N: int, boxr: np.ndarray, frames: np.ndarray, settings: Mapping, curves: bool):
        self.N, self.boxr, self.curves = N, boxr, curves
        self.cf = set(evenly(frames, int(settings["correlation_frames"])).tolist()) if curves else set()
        self.mods, self.g6s, self.grs, self.cgs = [], [], [], []
        self.r = self.dxs = None
        self.spacing = cage.neighbour_spacing(N, boxr)
        self.dr, self.gdx = float(settings["g6_dr"]), float(settings["gr_dx"])
        self.method = correlation_method(settings.get("correlations", DEFAULT_CORRELATIONS), N)  # ValueError
        self.h = correlation_fft.pipeline_spacing(boxr, self.dr, self.gdx)
        self.conf = float(settings["label_confidence"])

    def add(self, f, P: np.ndarray, vn) -> None:
        boxr, dr, spacing = self.boxr, self.dr, self.spacing
        ps = order.psi6(P, boxr, vn.nlist)
        mod, ang = order.global_psi6(ps)
        self.mods.append(mod)
        if int(f) in self.cf and self.method == "fft":
            G1 = order.first_shell_vectors(P, boxr, ang, spacing)
            c = correlation_fft.correlations(P, boxr, psi=ps, G=G1, orientation=ang, dr=dr, dx=self.gdx, h=self.h)
            self.r, self.dxs = c.r, c.x
            self.g6s.append(c.G6)
            self.grs.append(c.Gr)
            self.cgs.append(c.C_G1)
        elif int(f) in self.cf:
            self.r, g = order.g6(P, boxr, ps, dr=dr)
            pairs = order.pair_vectors(P, boxr, order.max_range(boxr))  # one query for G_r and C_G1
            self.dxs, gr = order.gr_cut(P, boxr, ang, dx=self.gdx, vectors=pairs)
            G1 = order.first_shell_vectors(P, boxr, ang, spacing)
            _, cg = order.shell_correlation(pairs, G1, dr=dr, r_max=order.max_range(boxr))
            del pairs
            self.g6s.append(g)
            self.grs.append(gr)
            self.cgs.append(cg)

    def finish(self):
        sc, cv = {}, {}
        if self.mods:
            ta = time_average(np.asarray(self.mods))
            sc["psi6"], sc["psi6_err"] = ta.mean, ta.err
        else:
            sc["psi6"] = sc["psi6_err"] = np.nan
        N, conf, r, dxs = self.N, self.conf, self.r, self.dxs
        if not self.curves:
            sc.update(kthny_observables(None, None, None, None, N, conf, np.nan))
            return sc, cv
        g6s, grs, cgs = self.g6s, self.grs, self.cgs
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # bins without pairs in every frame
            cv["G6"] = (r, np.nanmean(np.asarray(g6s), axis=0) if r.size else r.copy())
            cv["Gr"] = (dxs, np.mean(np.asarray(grs), axis=0))
            cv["C_G1"] = (r, np.nanmean(np.asarray(cgs), axis=0) if r.size else r.copy())
        sc.update(kthny_observables(r, np.asarray(g6s), dxs, np.asarray(grs), N, conf, self.spacing,
                                    np.asarray(cgs), self.boxr))
        return sc, cv


def kthny_observables(r, g6_frames, dx, gr_frames, n_cells: int, confidence: float, spacing: float,
                      cg_frames=None, box=None) -> dict:
    """KTHNY fits and label from the per-frame G6(r), G_r(dx, 0) and C_G1(r) (NaN without curves)."""
    out = {k: np.nan for k in KTHNY_SCALARS}
    out["kthny_reason"] = "correlations not computed"
    out["kthny_reason_code"] = float(reason_value("not_computed"))
    if r is None or g6_frames.size == 0 or gr_frames.size == 0:
        return out
    G6, G6e = frame_mean(g6_frames)
    Gr, Gre = frame_mean(gr_frames)
    CG, CGe = frame_mean(cg_frames) if cg_frames is not None and cg_frames.size else (None, None)
    fits = kthny.kthny_fits(r, G6, dx, Gr, G6_err=G6e, Gr_err=Gre, spacing=spacing, C_G1=CG, C_G1_err=CGe,
                            box=box)
    lab = kthny.classify_kthny(fits, min_confidence=confidence, n_cells=n_cells)
    for k in KTHNY_FITS:
        out[k] = float(fits.get(k, np.nan))
    out.update(kthny=float(lab.code), kthny_confidence=lab.confidence, kthny_reason=lab.reason,
               kthny_reason_code=float(reason_value(lab.reason_code)))
    return out


def frame_mean(curves: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean over frames of per-frame curves and its standard error (NaN with one frame).

    Parameters
    ----------
    curves : ndarray, shape (frames, bins)
        NaN where a frame has no value in a bin.

    Returns
    -------
    mean, err : ndarray, shape (bins,)
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # bins without pairs in some frames
        m = np.nanmean(curves, axis=0)
        n = np.sum(np.isfinite(curves), axis=0)
        if curves.shape[0] > 1:
            e = np.nanstd(curves, axis=0, ddof=1) / np.sqrt(np.maximum(n, 1))
        else:
            e = np.full(m.shape, np.nan)
    return m, e
