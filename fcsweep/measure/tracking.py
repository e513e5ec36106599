"""Linking cells across frames by the overlap of their masks, and the MSD of the tracks.

Two masks in successive frames are the same cell when each is the other's partner of
largest overlap and the overlap covers more than :data:`MIN_OVERLAP` of the smaller mask.
This holds while cells move less than about half their radius between frames, the usual
case of time-lapse movies of monolayers; a cell that is not linked starts a new track
(division, a cell entering the field of view, a jump).
"""

from __future__ import annotations

import numpy as np

from fcsweep.analysis.cage import cage_breaking, neighbour_spacing
from fcsweep.analysis.diffusion import effective_diffusion, estimate_diffusion, free_diffusion
from fcsweep.analysis.voronoi_open import open_voronoi
from fcsweep.analysis.msd import msd_curve

__all__ = ["link_frames", "tracked_msd", "tracked_diffusion", "tracked_cages", "bond_changes", "MIN_OVERLAP"]

#: Overlap, as a fraction of the smaller of two masks, above which they may be one cell.
MIN_OVERLAP = 0.5


def link_frames(prev: np.ndarray, prev_tracks: dict, frame: np.ndarray, labels: np.ndarray,
                next_id: int) -> tuple[np.ndarray, int]:
    """Track ids of the cells ``labels`` of ``frame``, continuing those of ``prev``.

    Parameters
    ----------
    prev : ndarray of int, shape (Y, X) or None
        The previous label frame (None for the first frame).
    prev_tracks : dict
        Label of ``prev`` -> track id.
    frame : ndarray of int, shape (Y, X)
    labels : ndarray of int
        The labels of ``frame`` to give ids, in order.
    next_id : int
        First id free for new tracks.

    Returns
    -------
    ids : ndarray of int, shape (len(labels),)
    next_id : int
        The next free id.
    """
    ids = np.full(len(labels), -1, dtype=np.int64)
    if prev is not None:
        both = (prev > 0) & (frame > 0)
        base = int(frame.max()) + 1
        key = prev[both].astype(np.int64)  # the pair (prev label, label) of each shared pixel, built in place
        key *= base
        key += frame[both]
        del both
        pairs, overlap = np.unique(key, return_counts=True)
        del key
        pl, cl = pairs // base, pairs % base
        area_p = np.bincount(prev.ravel())
        area_c = np.bincount(frame.ravel())
        ok = overlap > MIN_OVERLAP * np.minimum(area_p[pl], area_c[cl])
        pl, cl, overlap = pl[ok], cl[ok], overlap[ok]
        order = np.argsort(-overlap, kind="stable")
        used_p, used_c = set(), {}
        for k in order:
            if pl[k] in used_p or cl[k] in used_c:
                continue
            used_p.add(pl[k])
            used_c[cl[k]] = prev_tracks.get(int(pl[k]), -1)
        pos = {int(lab): i for i, lab in enumerate(labels)}
        for lab, tid in used_c.items():
            if int(lab) in pos and tid >= 0:
                ids[pos[int(lab)]] = tid
    for i in np.flatnonzero(ids < 0):
        ids[i] = next_id
        next_id += 1
    return ids, next_id


def tracked_msd(x: np.ndarray, y: np.ndarray):
    """Drift-subtracted MSD of the tracks present in every frame.

    Parameters
    ----------
    x, y : ndarray, shape (T, n_tracks)
        Centroids, NaN where a track is absent.

    Returns
    -------
    msd : ndarray, shape (T,)
        At lag ``m`` frames (:func:`fcsweep.analysis.msd.msd_curve`); NaN without such a track
        or with one frame.
    n : int
        Tracks used.
    """
    full = np.all(np.isfinite(x), axis=0) & np.all(np.isfinite(y), axis=0)
    T, n = x.shape[0], int(full.sum())
    if T < 2 or n == 0:
        return np.full(T, np.nan), n
    msd, _ = msd_curve(np.stack([x[:, full], y[:, full]], axis=-1))
    return msd, n


def tracked_diffusion(t: np.ndarray, x: np.ndarray, y: np.ndarray, *, v0=None, Dr=None) -> dict:
    """Long-time self-diffusion of the tracks present in every frame, in the user's units.

    The simulations' estimator (:func:`fcsweep.analysis.diffusion.estimate_diffusion`): the
    active-Brownian fit ``4 D t + A (1 - exp(-Dr t)) + c`` when ``Dr`` is given, else the
    linear fit ``4 D t + c``, over time blocks, with the error from the scatter of the cells'
    slopes (collective motion counted).  ``D_eff = D_s / D0``, ``D0 = v0^2 / (2 Dr)``, needs
    both ``v0`` and ``Dr`` (in the user's units), which images do not give.

    Returns
    -------
    dict
        ``D_s``, ``D_s_err``, ``D_s_diffusive`` (1 when the slope has settled and, with
        ``Dr``, the movie spans at least 8 / Dr; else 0),
        ``D_eff``, ``D_eff_err``; NaN where they cannot be computed.
    """
    nan = float("nan")
    out = dict(D_s=nan, D_s_err=nan, D_s_diffusive=nan, D_eff=nan, D_eff_err=nan)
    full = np.all(np.isfinite(x), axis=0) & np.all(np.isfinite(y), axis=0)
    if x.shape[0] < 3 or full.sum() < 2:
        return out
    est = estimate_diffusion(t, np.stack([x[:, full], y[:, full]], axis=-1), Dr=float(Dr) if Dr else 0.0)
    if not np.isfinite(est.D):
        return out
    out.update(D_s=float(est.D), D_s_err=float(est.D_err), D_s_diffusive=float(est.diffusive and est.long_enough))
    if v0 is not None and Dr:
        out["D_eff"], out["D_eff_err"] = effective_diffusion(est.D, est.D_err, float(v0), float(Dr))
    return out


def tracked_cages(t: np.ndarray, x: np.ndarray, y: np.ndarray, bounds, n_cells: float, *, v0=None, Dr=None):
    """Cage-relative MSD, ``F_s``, ``tau_alpha`` and the cage test of the tracked cells.

    The simulations' estimator (:func:`fcsweep.analysis.cage.cage_breaking`) with the
    Voronoi neighbours of the tracked cells in the open field of view
    (:func:`fcsweep.analysis.voronoi_open.open_voronoi`) at each time origin, and the
    neighbour spacing ``a`` of the density of all cells (``n_cells`` per field of view, a
    cell cut by the edge counted as half).

    Returns
    -------
    CageBreaking or None
        None without three frames and four tracks present in every frame.
    scalars : dict
        ``neighbour_spacing``, ``cage_msd_ratio`` (+ ``_err``), ``cage_broken_probability``,
        ``tau_alpha``, ``D_s_cr_late`` (+ ``_err``, length^2 / time) and ``D_eff_cr_late``
        (+ ``_err``, with ``v0`` and ``Dr``).
    """
    nan = float("nan")
    keys = ("neighbour_spacing", "cage_msd_ratio", "cage_msd_ratio_err", "cage_broken_probability", "tau_alpha",
            "D_s_cr_late", "D_s_cr_late_err", "D_eff_cr_late", "D_eff_cr_late_err")
    out = dict.fromkeys(keys, nan)
    full = np.all(np.isfinite(x), axis=0) & np.all(np.isfinite(y), axis=0)
    if x.shape[0] < 3 or full.sum() < 4:
        return None, out
    x0, x1, y0, y1 = bounds
    pos = np.stack([x[:, full] - x0, y[:, full] - y0], axis=-1)
    box = (x1 - x0, y1 - y0)

    def bonds(p):
        g = open_voronoi(p, (0.0, box[0], 0.0, box[1]))
        return g.i, g.j

    cb = cage_breaking(t, pos, box, spacing=neighbour_spacing(max(n_cells, 1.0), box), neighbours=bonds)
    D0 = free_diffusion(v0, Dr) if (v0 is not None and Dr) else nan
    out.update(neighbour_spacing=cb.spacing, cage_msd_ratio=cb.ratio, cage_msd_ratio_err=cb.ratio_err,
               cage_broken_probability=cb.p_broken, tau_alpha=cb.tau_alpha, D_s_cr_late=cb.D_late,
               D_s_cr_late_err=cb.D_late_err)
    if np.isfinite(D0) and D0 > 0:
        out.update(D_eff_cr_late=cb.D_late / D0, D_eff_cr_late_err=cb.D_late_err / D0)
    return cb, out


def bond_changes(prev_bonds, prev_ids, bonds, ids) -> float:
    """Fraction of the neighbour bonds that changed between two frames.

    Only bonds between tracks classified in both frames count: the bonds gained or lost,
    over the bonds present in either frame (0: no neighbour changed; a T1 event changes 2
    of about 3 N bonds).

    Parameters
    ----------
    prev_bonds, bonds : ndarray of int, shape (B, 2)
        Cell-index pairs of classified cells (:func:`fcsweep.measure.frames.frame_statistics`).
    prev_ids, ids : ndarray of int
        Track id of each cell index of the two frames.

    Returns
    -------
    float
        NaN when no bond qualifies.
    """
    a = {tuple(sorted(p)) for p in prev_ids[prev_bonds].tolist()}
    b = {tuple(sorted(p)) for p in ids[bonds].tolist()}
    tracks = {t for p in a for t in p} & {t for p in b for t in p}
    a = {p for p in a if p[0] in tracks and p[1] in tracks}
    b = {p for p in b if p[0] in tracks and p[1] in tracks}
    union = a | b
    return len(a ^ b) / len(union) if union else float("nan")
