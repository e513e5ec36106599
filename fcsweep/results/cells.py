"""The frames an export reads: frame selection, per-cell quantities (shape index, Voronoi
defects, defect clusters) and contours, one block of frames at a time.

Shared by the writers of :mod:`fcsweep.results.export` (GSD) and :mod:`fcsweep.results.vtk`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from fcsweep.analysis import confined, shapes, voronoi
from fcsweep.io.trajectory import Trajectory, TrajectoryError, open_trajectory
from fcsweep.model.confinement import confinement_of_params
from fcsweep.model.shape import radius

#: Export formats and the suffix of their output.
FORMATS = {"gsd": ".gsd", "vtk": ".pvd"}
#: Trajectory values read at once (per block of frames): bounds an export's memory.
BLOCK_BYTES = 32 << 20
#: Contour points when the trajectory does not record the model's ``contour_points``.
DEFAULT_CONTOUR_POINTS = 40


# ------------------------------------------------------------------ frame selection

def parse_frames(spec, n_frames: int) -> np.ndarray:
    """Frame indices selected by ``spec``, in the given order without repeats.

    Parameters
    ----------
    spec : None, str, int, slice or sequence of int
        ``None``, ``"all"`` or ``":"``: every frame; ``"-1"``: the last; ``"0:100:10"``:
        a Python slice; ``"0,5,-1"``: a list (items may be slices).  Negative indices count
        from the end.
    n_frames : int

    Returns
    -------
    ndarray of int64
        Non-negative frame indices.

    Raises
    ------
    ValueError
        For a malformed spec, an index out of range, or a selection with no frame.
    """
    n = int(n_frames)
    every = np.arange(n, dtype=np.int64)
    if spec is None:
        return every
    if isinstance(spec, slice):
        parts = [spec]
    elif isinstance(spec, (int, np.integer)):
        parts = [int(spec)]
    elif isinstance(spec, str):
        text = spec.strip().lower()
        if text in ("", "all", ":"):
            return every
        parts = []
        for item in text.split(","):
            item = item.strip()
            try:
                if ":" in item:
                    fields = item.split(":")
                    if len(fields) > 3:
                        raise ValueError
                    parts.append(slice(*(int(x) if x.strip() else None for x in fields)))
                else:
                    parts.append(int(item))
            except ValueError:
                raise ValueError(f"frames {spec!r}: expected 'all', an index like -1, a slice like 0:100:10 "
                                 f"or a comma-separated list of these") from None
    else:
        parts = [int(k) for k in spec]
    out = []
    for p in parts:
        if isinstance(p, slice):
            if p.step == 0:
                raise ValueError(f"frames {spec!r}: slice step cannot be zero")
            out.extend(every[p].tolist())
        elif -n <= p < n:
            out.append(p % n)
        else:
            raise ValueError(f"frames {spec!r}: index {p} out of range for {n} frames")
    idx = np.asarray(list(dict.fromkeys(out)), dtype=np.int64)
    if idx.size == 0:
        raise ValueError(f"frames {spec!r} selects no frame of {n}")
    return idx


# ------------------------------------------------------------------ per-frame quantities

def cluster_ids(defect: np.ndarray, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """Defect cluster of every cell: connected defect cells over the bonds ``(i, j)``.

    Returns
    -------
    ndarray of int64, shape (N,)
        0 for the largest cluster, 1 for the next ... (equal sizes ordered by their lowest
        cell index); -1 for cells that are not defects.  The sizes agree with
        :func:`fcsweep.analysis.voronoi.defect_clusters`.
    """
    defect = np.asarray(defect, dtype=bool)
    N = defect.size
    ids = np.full(N, -1, dtype=np.int64)
    idx = np.flatnonzero(defect)
    if idx.size == 0:
        return ids
    keep = defect[i] & defect[j]
    g = coo_matrix((np.ones(int(keep.sum())), (i[keep], j[keep])), shape=(N, N)).tocsr()
    _, labels = connected_components(g, directed=False)
    _, inv, counts = np.unique(labels[idx], return_inverse=True, return_counts=True)
    first = np.full(counts.size, N, dtype=np.int64)
    np.minimum.at(first, inv, idx)
    order = np.lexsort((first, -counts))
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    ids[idx] = rank[inv]
    return ids


def cell_contours(pos, theta, a, b, R0: float = 1.0, points: int = DEFAULT_CONTOUR_POINTS) -> np.ndarray:
    """Contour points of every cell, ``r_i + R(phi_k) e(theta_i + phi_k)``.

    Parameters
    ----------
    pos : ndarray, shape (N, 2)
    theta : ndarray, shape (N,)
    a, b : ndarray, shape (N, M-1)
        Mode amplitudes (width 0: discs of radius R0).
    R0 : float
    points : int
        Contour points K, at body angles ``phi_k = 2 pi k / K`` (counterclockwise).

    Returns
    -------
    ndarray, shape (N, K, 2)
    """
    pos = np.asarray(pos, dtype=float)
    N, K = pos.shape[0], int(points)
    phi = 2.0 * np.pi * np.arange(K) / K
    R0 = np.asarray(R0, dtype=float)
    if R0.ndim:  # per-cell radii (cell size differences)
        R0 = R0.reshape(N, 1)
    if np.shape(a)[-1] == 0:
        R = np.broadcast_to(R0, (N, K)).astype(float)
    else:
        R = np.atleast_2d(radius(phi, a, b, R0)[0])
    ang = np.asarray(theta, dtype=float)[:, None] + phi[None, :]
    return pos[:, None, :] + R[..., None] * np.stack([np.cos(ang), np.sin(ang)], axis=-1)


@dataclass
class CellFrame:
    """One frame of a trajectory with the per-cell quantities an export writes.

    Attributes
    ----------
    index, step : int
    time : float
    position : ndarray, shape (N, 2)
        Centroids wrapped into ``[0, Lx) x [0, Ly)``.
    image : ndarray of int, shape (N, 2)
        Periodic images: unwrapped centroid = ``position + image * box``.
    theta : ndarray, shape (N,)
    a, b : ndarray, shape (N, M-1)
    q : ndarray, shape (N,)
    n_sides, cluster : ndarray of int, shape (N,), or None
    defect : ndarray of bool, shape (N,), or None
        None when the frame was read without the Voronoi tessellation.
    """

    index: int
    step: int
    time: float
    position: np.ndarray
    image: np.ndarray
    theta: np.ndarray
    a: np.ndarray
    b: np.ndarray
    q: np.ndarray
    n_sides: np.ndarray | None
    defect: np.ndarray | None
    cluster: np.ndarray | None

    def unwrapped(self, box) -> np.ndarray:
        """Unwrapped centroids, shape (N, 2)."""
        return self.position + self.image * np.asarray(box, dtype=float)

    def per_cell(self) -> dict:
        """Per-cell arrays by export name: q, defect, n_sides, cluster (if known), theta,
        a2.., b2.."""
        out = {"q": self.q}
        if self.defect is not None:
            out.update(defect=self.defect.astype(np.uint8), n_sides=self.n_sides, cluster=self.cluster)
        out["theta"] = self.theta
        for k in range(self.a.shape[1]):
            out[f"a{k + 2}"] = self.a[:, k]
        for k in range(self.b.shape[1]):
            out[f"b{k + 2}"] = self.b[:, k]
        return out


def run_confinement_of(traj: Trajectory):
    """The well or channel of a trajectory (its parameters and radii; host-box lengths), or
    None for the periodic box."""
    if str(traj.params.get("boundary", "periodic")) == "periodic":
        return None
    return confinement_of_params({**dict(traj.params), "N": traj.n_cells}, getattr(traj, "radii", None))


def _frame_of(traj: Trajectory, k: int, pos, img, theta, a, b, defects: bool, radii=None, conf=None) -> CellFrame:
    box = np.asarray(traj.box, dtype=float)
    wrapped = np.mod(pos, box)
    img = img + np.round((pos - wrapped) / box).astype(np.int64)  # keeps position + image * box
    n_sides = defect = cluster = None
    if defects and conf is not None:  # a well or channel: the defects the analysis counts
        tess = confined.confined_voronoi(wrapped, conf)
        counted = confined.counted_cells(wrapped, conf, tess, confined.lattice_spacing(conf, len(wrapped)))
        n_sides, defect = tess.n_sides, counted & (tess.n_sides != 6)
        cluster = cluster_ids(defect, tess.i, tess.j)
    elif defects:
        vn = voronoi.voronoi_neighbors(wrapped, box, radii)
        n_sides, defect = vn.n_sides, voronoi.defect_mask(vn.n_sides)
        cluster = cluster_ids(defect, vn.i, vn.j)
    return CellFrame(int(k), int(traj.step[k]), float(traj.time[k]), wrapped, img, theta, a, b,
                     shapes.shape_indices(a, b), n_sides, defect, cluster)


def iter_frames(traj: Trajectory, frames, *, defects: bool = True):
    """:class:`CellFrame` of each frame index in ``frames``, read in blocks of at most
    :data:`BLOCK_BYTES` (consecutive indices are read with one slice per field).
    ``defects=False`` skips the Voronoi tessellation (most of the time for large N)."""
    frames = np.asarray(frames, dtype=np.int64)
    N, width = traj.n_cells, traj.modes_width
    per_frame = 8 * N * (2 + 2 + 1 + 2 * width)
    rows = max(1, BLOCK_BYTES // max(per_frame, 1))
    has = set(traj.fields)
    radii = getattr(traj, "radii", None) if defects else None  # sizes differ: the radical tessellation
    conf = run_confinement_of(traj) if defects else None
    for lo in range(0, frames.size, rows):
        block = frames[lo:lo + rows]
        pos = traj.read("position", block)
        img = traj.read("image", block).astype(np.int64) if "image" in has else np.zeros(pos.shape, np.int64)
        theta = traj.read("theta", block) if "theta" in has else np.zeros(pos.shape[:2])
        if {"shape_a", "shape_b"} <= has:
            a, b = traj.read("shape_a", block), traj.read("shape_b", block)
        else:
            a = b = np.zeros(pos.shape[:2] + (0,))
        for r, k in enumerate(block):
            yield _frame_of(traj, int(k), pos[r], img[r], theta[r], a[r], b[r], defects, radii, conf)


def traj_contour_points(traj: Trajectory) -> int:
    try:
        return int(traj.params.get("contour_points", DEFAULT_CONTOUR_POINTS))
    except (TypeError, ValueError):
        return DEFAULT_CONTOUR_POINTS


def progress_bar(total, desc, progress):
    from tqdm.auto import tqdm

    return tqdm(total=total, desc=desc, unit="frame", disable=not progress)


def open_nonempty(traj_path) -> Trajectory:
    traj = open_trajectory(traj_path)
    if traj.n_frames == 0:
        raise TrajectoryError(f"{traj.path}: no frames to export")
    return traj
