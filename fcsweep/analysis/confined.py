"""Observables of a confined run (a circular well or a channel): arrays in, numbers out.

A confined run (``boundary: well`` or ``channel``, :mod:`fcsweep.model.confinement`) keeps
its cells in a periodic *host* box that holds the well or channel with an empty margin on
every walled side; positions are host-box coordinates.  What changes in the analysis
(docs/statistics.md, "Confined runs: what the analysis measures"):

* **No minimum image across a wall.**  The Voronoi tessellation is open (scipy's Qhull)
  in a well, and periodic along x only in a channel (the cells copied by +-L_x, as many
  copies as a vertex circle can span); bond vectors take the minimum image along x only.
* **Which cells are counted.**  A cell is *counted* by the defect statistics, |Psi6| and
  the cage rule when (1) its side count is certain: its Voronoi region is bounded and the
  empty circle of every one of its vertices lies inside the walls (the interior rule of
  :mod:`fcsweep.analysis.voronoi_open`, with the wall as the edge of the field of view),
  and (2) its centre lies at least :data:`WALL_SPACINGS` lattice spacings ``a`` from the
  nearest wall, ``a = (2 A / (sqrt(3) N))^(1/2)`` with A the area inside the walls (at
  equal radii ``a = (2 pi R0^2 / (sqrt(3) phi))^(1/2)``, phi = ``conf.area_fraction``).
  rho_d and P_max are fractions of the counted cells; the number counted is stored.
* **The wall's pressure** (:func:`pressure_series`): the inward-normal wall forces summed
  over the cells per unit wall length, per frame (:func:`fcsweep.model.confinement.wall_pressure`).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import ConvexHull, Voronoi

from fcsweep.analysis.stats import time_average
from fcsweep.analysis.voronoi import cluster_size_counts, defect_clusters, shuffled_defects
from fcsweep.model.confinement import Confinement, wall_pressure

__all__ = ["WALL_SPACINGS", "ConfinedVoronoi", "scaled_confinement", "lattice_spacing", "confined_voronoi",
           "counted_cells", "frame_defects", "confined_defect_statistics", "confined_psi6", "pressure_series",
           "pressure_observables", "wall_distance_mask"]

#: Counted cells lie at least this many lattice spacings a from the nearest wall.
WALL_SPACINGS = 2.0


def scaled_confinement(conf: Confinement, length: float) -> Confinement:
    """The same confinement with lengths in units of ``length`` (areas in ``length^2``)."""
    s = float(length)
    return dataclasses.replace(conf, size=conf.size / s, host=np.asarray(conf.host, float) / s,
                               centre=np.asarray(conf.centre, float) / s, cell_area=conf.cell_area / s ** 2)


def lattice_spacing(conf: Confinement, n_cells: int) -> float:
    """Spacing ``a`` of a triangular lattice of ``n_cells`` points on the area inside the
    walls, ``(2 A / (sqrt(3) N))^(1/2)`` (conf's length unit)."""
    return float(math.sqrt(2.0 * conf.area / (math.sqrt(3.0) * int(n_cells))))


@dataclass
class ConfinedVoronoi:
    """Voronoi bonds of one frame of a confined run.

    Attributes
    ----------
    i, j : ndarray of int, shape (B,)
        Directed bonds ``i -> j`` (both directions present), one per Voronoi edge of i.
    vectors : ndarray, shape (B, 2)
        ``r_j - r_i``, minimum image along x in a channel, direct in a well.
    n_sides : ndarray of int, shape (N,)
        Voronoi edges per cell (certain only where ``certain``).
    certain : ndarray of bool, shape (N,)
        Region bounded and every vertex's empty circle inside the walls.
    """

    i: np.ndarray
    j: np.ndarray
    vectors: np.ndarray
    n_sides: np.ndarray
    certain: np.ndarray


def _copies(pos: np.ndarray, conf: Confinement) -> tuple[np.ndarray, int]:
    """The points and their copies along x (channel; a well has none) and the index of the
    central copy: enough copies that no vertex circle inside the channel (radius <= W / 2)
    reaches past them."""
    if conf.kind == "well":
        return pos, 0
    Lx = float(conf.host[0])
    n = int(math.ceil(conf.size / Lx)) + 1
    shifts = np.arange(-n, n + 1)
    pts = np.concatenate([pos + np.array([s * Lx, 0.0]) for s in shifts])
    return pts, n


def _voronoi_ridges(pts: np.ndarray):
    """Ridges of the Voronoi tessellation of ``pts``: ridge points (E, 2), ridge vertices
    (E, 2; -1 at infinity), vertices (V, 2) and each vertex's empty-circle radius (V,)."""
    vor = Voronoi(pts)
    rp = np.asarray(vor.ridge_points, np.int64)
    rv = np.array([r if len(r) == 2 else [-1, -1] for r in vor.ridge_vertices], np.int64).reshape(-1, 2)
    verts = np.asarray(vor.vertices, float)
    reach = np.full(len(verts), np.inf)
    for k in (0, 1):
        ok = rv[:, k] >= 0
        reach[rv[ok, k]] = np.linalg.norm(verts[rv[ok, k]] - pts[rp[ok, 0]], axis=1)
    return rp, rv, verts, reach


def _power_ridges(pts: np.ndarray, radii: np.ndarray):
    """Ridges of the radical (Laguerre, power) tessellation of discs of ``radii`` at ``pts``,
    as :func:`_voronoi_ridges`; a vertex's reach is the distance beyond which no disc of
    radius <= max(radii) can change it, sqrt(pi + R_max^2) with pi its power (for equal radii
    the empty-circle radius)."""
    w = np.asarray(radii, float) ** 2
    hull = ConvexHull(np.column_stack([pts, (pts ** 2).sum(axis=1) - w]))
    faces = hull.simplices[hull.equations[:, 2] < 0]  # the lower hull: the regular triangulation
    p, q, r = (pts[faces[:, k]] for k in range(3))
    lift = (pts ** 2).sum(axis=1) - w
    lp, lq, lr = (lift[faces[:, k]] for k in range(3))
    A = np.stack([2.0 * (q - p), 2.0 * (r - p)], axis=1)  # (T, 2, 2)
    verts = np.linalg.solve(A, np.stack([lq - lp, lr - lp], axis=1)[..., None])[..., 0]
    power = ((verts - p) ** 2).sum(axis=1) - w[faces[:, 0]]
    reach = np.sqrt(np.maximum(power + w.max(), 0.0))
    edges = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    tri = np.tile(np.arange(len(faces)), 3)
    key = np.sort(edges, axis=1)
    uniq, inv, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    order = np.argsort(inv.ravel(), kind="stable")
    start = np.concatenate(([0], np.cumsum(counts)[:-1]))
    # each ridge's two triangles; a ridge on the hull's rim has one (unbounded: -1)
    rv = np.full((len(uniq), 2), -1, np.int64)
    two = counts == 2
    rv[two, 0] = tri[order[start[two]]]
    rv[two, 1] = tri[order[start[two] + 1]]
    return uniq.astype(np.int64), rv, verts, reach


def confined_voronoi(pos, conf: Confinement, radii=None) -> ConfinedVoronoi:
    """The Voronoi tessellation of the centres ``pos`` (N, 2) inside a well or channel
    (host-box coordinates, the same length unit as ``conf``); with per-cell ``radii`` the
    radical (Laguerre) tessellation, whose edges lie where the tangent lengths to two discs
    are equal (cell size differences, as :func:`fcsweep.analysis.voronoi.laguerre_bonds`).

    Parameters
    ----------
    pos : array_like, shape (N, 2)
    conf : Confinement
    radii : array_like, shape (N,), optional
        Per-cell radii (conf's length unit).

    Returns
    -------
    ConfinedVoronoi
        With fewer than 4 cells no bond and no certain cell.
    """
    pos = np.asarray(pos, float).reshape(-1, 2)
    N = len(pos)
    if conf.kind == "channel":
        pos = pos.copy()
        pos[:, 0] = np.mod(pos[:, 0], float(conf.host[0]))
    if N < 4:
        z = np.zeros(0, np.int64)
        return ConfinedVoronoi(z, z.copy(), np.zeros((0, 2)), np.zeros(N, np.int64), np.zeros(N, bool))
    pts, centre = _copies(pos, conf)
    if radii is None:
        rp, rv, verts, reach = _voronoi_ridges(pts)
    else:
        rp, rv, verts, reach = _power_ridges(pts, np.tile(np.asarray(radii, float).reshape(N), len(pts) // N))
    lo, hi = centre * N, centre * N + N
    # a vertex is sound when finite and no cell beyond the walls could change it
    sound_v = conf.inside_distance(verts) >= reach if len(verts) else np.zeros(0, bool)
    sound = (rv >= 0).all(axis=1)
    sound[sound] = sound_v[rv[sound, 0]] & sound_v[rv[sound, 1]]
    bad = np.zeros(len(pts), bool)
    np.logical_or.at(bad, rp[~sound].ravel(), True)
    a = np.concatenate([rp[:, 0], rp[:, 1]])
    b = np.concatenate([rp[:, 1], rp[:, 0]])
    mine = (a >= lo) & (a < hi)
    a, b = a[mine], b[mine]
    vec = pts[b] - pts[a]
    i, j = a - lo, b % N
    order = np.lexsort((j, i))
    i, j, vec = i[order], j[order], vec[order]
    has = np.zeros(N, bool)
    has[i] = True
    certain = ~bad[lo:hi] & has
    return ConfinedVoronoi(i, j, vec, np.bincount(i, minlength=N).astype(np.int64), certain)


def wall_distance_mask(pos, conf: Confinement, spacing: float) -> np.ndarray:
    """Cells whose centre lies at least :data:`WALL_SPACINGS` x ``spacing`` from the
    nearest wall (positions taken modulo the host box)."""
    p = np.mod(np.asarray(pos, float).reshape(-1, 2), np.asarray(conf.host, float))
    return conf.inside_distance(p) >= WALL_SPACINGS * float(spacing)


def counted_cells(pos, conf: Confinement, tess: ConfinedVoronoi, spacing: float) -> np.ndarray:
    """The cells the statistics count: side count certain and at least
    :data:`WALL_SPACINGS` spacings from the wall (module docstring)."""
    return tess.certain & wall_distance_mask(pos, conf, spacing)


def frame_defects(tess: ConfinedVoronoi, counted: np.ndarray, frame_index: int) -> dict:
    """Defects and clusters of one frame over the counted cells.

    Parameters
    ----------
    tess : ConfinedVoronoi
    counted : ndarray of bool, shape (N,)
        :func:`counted_cells`.
    frame_index : int
        Trajectory index of the frame (seed of the shuffled labels,
        :func:`fcsweep.analysis.voronoi.shuffled_defects`).

    Returns
    -------
    dict
        ``rho_d`` (defects / counted), ``pmax`` and ``pmax_shuffled`` (largest cluster /
        counted; the labels permuted over the counted cells), ``sizes`` (cluster sizes),
        ``n_counted``, ``sides`` (counted cells with 0..12 sides); NaN fractions when no
        cell is counted.  Clusters join counted defects over bonds between counted cells.
    """
    counted = np.asarray(counted, bool)
    n = int(counted.sum())
    sides = np.bincount(np.minimum(tess.n_sides[counted], 12), minlength=13)
    if n == 0:
        nan = float("nan")
        return {"rho_d": nan, "pmax": nan, "pmax_shuffled": nan, "sizes": np.zeros(0, np.int64), "n_counted": 0,
                "sides": sides}
    d = counted & (tess.n_sides != 6)
    sizes = defect_clusters(d, tess.i, tess.j)
    shuf = np.zeros_like(d)
    shuf[counted] = shuffled_defects(d[counted], frame_index)
    ss = defect_clusters(shuf, tess.i, tess.j)
    return {"rho_d": float(d.sum()) / n, "pmax": (sizes[0] / n) if sizes.size else 0.0,
            "pmax_shuffled": (ss[0] / n) if ss.size else 0.0, "sizes": sizes, "n_counted": n, "sides": sides}


def confined_defect_statistics(frames_pos, conf: Confinement, spacing: float, frame_indices=None, each=None,
                               radii=None) -> dict:
    """:func:`fcsweep.analysis.voronoi.defect_statistics` of a confined run: the same keys,
    over the counted cells of each frame, plus ``n_counted_cells`` (mean over frames) and
    ``n_counted_frames`` (the per-frame counts).

    Parameters
    ----------
    frames_pos : ndarray (F, N, 2) or FrameSource
        Centres (host-box coordinates, the length unit of ``conf``).
    conf : Confinement
    spacing : float
        Lattice spacing a (:func:`lattice_spacing`).
    frame_indices : array_like of int, optional
        Trajectory index of each frame (default 0 .. F-1).
    each : callable, optional
        ``each(f, tess, counted)`` for every frame (the |Psi6| step reuses the tessellation).
    radii : array_like, shape (N,), optional
        Per-cell radii (cell size differences): the radical tessellation.
    """
    F, N = frames_pos.shape[:2]
    fi = np.arange(F) if frame_indices is None else np.asarray(frame_indices, np.int64)
    rho, pmax, pshuf, ncount = np.empty(F), np.empty(F), np.empty(F), np.empty(F)
    counts = np.zeros(N, np.int64)
    sides = np.zeros(13, np.int64)
    for f in range(F):
        P = np.asarray(frames_pos[f], float)
        tess = confined_voronoi(P, conf, radii)
        c = counted_cells(P, conf, tess, spacing)
        if each is not None:
            each(f, tess, c)
        r = frame_defects(tess, c, int(fi[f]))
        rho[f], pmax[f], pshuf[f], ncount[f] = r["rho_d"], r["pmax"], r["pmax_shuffled"], r["n_counted"]
        counts += cluster_size_counts(r["sizes"], N)
        sides += r["sides"]
    out = {"cluster_size_counts": counts, "n_sides_counts": sides, "n_frames": F, "rho_d_frames": rho,
           "largest_cluster_fraction_frames": pmax, "largest_cluster_fraction_shuffled_frames": pshuf,
           "n_counted_frames": ncount, "n_counted_cells": float(ncount.mean()) if F else float("nan")}
    for name, series in (("rho_d", rho), ("largest_cluster_fraction", pmax),
                         ("largest_cluster_fraction_shuffled", pshuf)):
        if F and np.all(np.isfinite(series)):
            ta = time_average(series)
            out.update({name: ta.mean, f"{name}_err": ta.err, f"{name}_start": ta.start})
        else:
            out.update({name: float("nan"), f"{name}_err": float("nan"), f"{name}_start": 0})
    return out


def confined_psi6(tess: ConfinedVoronoi, counted: np.ndarray) -> float:
    """``|Psi6|``: the modulus of the mean over the counted cells of
    ``psi6_i = <exp(6 i theta_ij)>_j`` over all Voronoi neighbours j of i (NaN if none)."""
    counted = np.asarray(counted, bool)
    if not counted.any():
        return float("nan")
    N = counted.size
    z = np.exp(6j * np.arctan2(tess.vectors[:, 1], tess.vectors[:, 0]))
    s = np.zeros(N, complex)
    np.add.at(s, tess.i, z)
    psi = s / np.maximum(tess.n_sides, 1)
    return float(np.abs(psi[counted].mean()))


def pressure_series(positions, theta, shape_a, shape_b, conf: Confinement, *, contour_points: int = 40,
                    quadrature: str = "arc", radii=None) -> np.ndarray:
    """The pressure on the wall in every frame (:func:`fcsweep.model.confinement.wall_pressure`).

    Parameters
    ----------
    positions : (F, N, 2) array or FrameSource
        Centres in host-box coordinates, length unit of ``conf`` (R0 = 1 there).
    theta : (F, N) array or FrameSource
        Contour orientations.
    shape_a, shape_b : (F, N, M - 1) arrays or FrameSources, or None
        Mode amplitudes (None: rigid discs).
    conf : Confinement
    contour_points, quadrature : the run's ``contour_points`` and ``quadrature``.
    radii : ndarray (N,), optional
        Per-cell radii in the length unit of ``conf``.

    Returns
    -------
    ndarray, shape (F,)
        Wall force per unit wall length (dimensionless: the wall energy is an area, its
        force a length).
    """
    F, N = positions.shape[:2]
    out = np.empty(F)
    empty = np.zeros((N, 0))
    for f in range(F):
        a = empty if shape_a is None else np.asarray(shape_a[f], float)
        b = empty if shape_b is None else np.asarray(shape_b[f], float)
        out[f] = wall_pressure(np.asarray(positions[f], float), np.asarray(theta[f], float), a, b, conf, R0=1.0,
                               contour_points=int(contour_points), quadrature=str(quadrature), radii=radii)
    return out


def pressure_observables(series) -> dict:
    """``wall_pressure`` and its 1-sigma error from a per-frame series: the time average
    after equilibration detection, with the error of a correlated series
    (:func:`fcsweep.analysis.stats.time_average`: the integrated autocorrelation time)."""
    s = np.asarray(series, float)
    if s.size == 0 or not np.all(np.isfinite(s)):
        return {"wall_pressure": float("nan"), "wall_pressure_err": float("nan")}
    ta = time_average(s)
    return {"wall_pressure": float(ta.mean), "wall_pressure_err": float(ta.err)}
