"""Export a trajectory for the viewers people already use: GSD (OVITO, MDAnalysis, freud,
HOOMD-blue tools) and VTK XML PolyData series (ParaView, VisIt, pyvista).

H5MD stays the native format; an export reads the trajectory one block of frames at a time
(:data:`BLOCK_BYTES`), so memory stays bounded however long the run, and never writes into
the run directory.

Per cell and frame both formats carry the shape index ``q``, the defect flag (Voronoi
neighbours != 6), the number of Voronoi neighbours ``n_sides``, the defect cluster id
``cluster`` (0 = largest cluster, ties broken by the lowest cell index; -1 for cells that are
not defects), the polarity angle ``theta`` and the Fourier coefficients ``a2 .. aM``,
``b2 .. bM`` (mode n = 2..M, docs/model.md).

GSD (HOOMD schema): the box is ``[Lx, Ly, 0, 0, 0, 0]`` with ``configuration/dimensions = 2``;
positions are the centroids in HOOMD's box centred at the origin, ``x - L/2`` (z = 0), with
``particles/image`` the periodic image counts (or, with ``unwrapped=True``, the unwrapped
centroids minus ``L/2`` and zero images); ``particles/orientation`` is the quaternion of a
rotation by ``theta`` about z.  Per-cell quantities are ``log/particles/<name>``, the time
``log/fcsweep/time``, and the run's parameters ``log/fcsweep/<name>`` (numbers) and
``log/fcsweep/parameters`` (all of them as JSON, UTF-8 bytes in an int8 array) in frame 0.
Each cell is drawn as a disc of the cell area (type ``cell``); with ``polygons=True`` each
cell is its own type whose ``Polygon`` shape is its contour in every frame (true shapes in
OVITO; JSON text of about 40 bytes per contour point, cell and frame).

VTK: one ``<stem>_<frame>.vtp`` per frame, each cell one closed polyline through its
``contour_points`` contour points (the model's resolution), with the per-cell quantities as
CellData and ``TimeValue``, ``step`` and ``box`` as FieldData, and ``<stem>.pvd`` listing
the files with their times.  Written with numpy only (base64 binary or ascii), so the core
install needs no VTK package.
"""

from __future__ import annotations

import base64
import json
from dataclasses import dataclass
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from fcsweep.analysis import shapes, voronoi
from fcsweep.analysis.trajectory import Trajectory, TrajectoryError, open_trajectory
from fcsweep.io.failures import remove_stale
from fcsweep.io.sweepdir import atomic_write
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
    if np.shape(a)[-1] == 0:
        R = np.full((N, K), float(R0))
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


def _frame_of(traj: Trajectory, k: int, pos, img, theta, a, b, defects: bool) -> CellFrame:
    box = np.asarray(traj.box, dtype=float)
    wrapped = np.mod(pos, box)
    img = img + np.round((pos - wrapped) / box).astype(np.int64)  # keeps position + image * box
    n_sides = defect = cluster = None
    if defects:
        vn = voronoi.voronoi_neighbors(wrapped, box)
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
            yield _frame_of(traj, int(k), pos[r], img[r], theta[r], a[r], b[r], defects)


def _contour_points(traj: Trajectory) -> int:
    try:
        return int(traj.params.get("contour_points", DEFAULT_CONTOUR_POINTS))
    except (TypeError, ValueError):
        return DEFAULT_CONTOUR_POINTS


def _progress(total, desc, progress):
    from tqdm.auto import tqdm

    return tqdm(total=total, desc=desc, unit="frame", disable=not progress)


def _open(traj_path) -> Trajectory:
    traj = open_trajectory(traj_path)
    if traj.n_frames == 0:
        raise TrajectoryError(f"{traj.path}: no frames to export")
    return traj


# ------------------------------------------------------------------ GSD

def _gsd_parameters(params: dict) -> dict:
    """Log entries of the run's parameters: numbers one by one, everything as JSON."""
    out = {}
    for key, v in sorted(params.items()):
        # float64 log entries; integers it cannot hold exactly (seeds) are in the JSON only
        if isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool) and abs(v) <= 2**53:
            out[f"fcsweep/{key}"] = np.array([v], dtype=np.float64)
    text = json.dumps(params, sort_keys=True, default=str).encode()
    out["fcsweep/parameters"] = np.frombuffer(text, dtype=np.int8).copy()
    return out


def _quaternion_z(theta) -> np.ndarray:
    half = 0.5 * np.asarray(theta, dtype=float)
    z = np.zeros_like(half)
    return np.stack([np.cos(half), z, z, np.sin(half)], axis=-1)


def export_gsd(traj_path, out, *, frames=None, unwrapped: bool = False, polygons: bool = False,
               defects: bool = True, progress: bool = True) -> Path:
    """Write a trajectory (or some of its frames) as a GSD file (HOOMD schema, 2-D).

    Parameters
    ----------
    traj_path : path-like
        A ``trajectory.h5`` (or a running run's ``.partial``, or a run directory).
    out : path-like
        The ``.gsd`` file to write (replaced if it exists, only once the new one is
        complete: :func:`fcsweep.io.sweepdir.atomic_write`, so a failed or interrupted
        export leaves the previous file and no partial one).
    frames : see :func:`parse_frames`
        Frames to export (default all).
    unwrapped : bool
        Write unwrapped centroids (minus ``L/2``) with zero images instead of wrapped
        centroids with their image counts.
    polygons : bool
        Give each cell its own particle type whose ``Polygon`` shape is its contour in every
        frame (viewers draw the true shapes); otherwise all cells are type ``cell``, drawn
        as discs of the cell area.
    defects : bool
        Include ``defect``, ``n_sides`` and ``cluster`` (a periodic Voronoi tessellation
        per frame: most of the export time for large N).
    progress : bool
        Show a progress bar (tqdm) on stderr.

    Returns
    -------
    Path
        ``out``.

    Raises
    ------
    ImportError
        If the ``gsd`` package is missing.
    fcsweep.analysis.trajectory.TrajectoryError
        If the trajectory cannot be read.
    ValueError
        For a bad ``frames`` spec.
    """
    try:
        import gsd.hoomd
    except ImportError as exc:
        raise ImportError("GSD export needs the gsd package: pip install gsd") from exc
    traj = _open(traj_path)
    idx = parse_frames(frames, traj.n_frames)
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    box = np.asarray(traj.box, dtype=float)
    half = box / 2.0
    R0 = float(traj.params.get("R0", 1.0))
    K = _contour_points(traj)
    N = traj.n_cells
    remove_stale(out.parent, (out.name,))

    def write(tmp: Path) -> None:
        with gsd.hoomd.open(str(tmp), "w") as f, _progress(idx.size, "export gsd", progress) as bar:
            for n, cf in enumerate(iter_frames(traj, idx, defects=defects)):
                fr = gsd.hoomd.Frame()
                fr.configuration.step = cf.step
                fr.configuration.box = [box[0], box[1], 0.0, 0.0, 0.0, 0.0]
                fr.configuration.dimensions = 2
                fr.particles.N = N
                xyz = np.zeros((N, 3), dtype=np.float32)
                image = np.zeros((N, 3), dtype=np.int32)
                if unwrapped:
                    xyz[:, :2] = cf.unwrapped(box) - half
                else:
                    xyz[:, :2] = cf.position - half
                    image[:, :2] = cf.image
                fr.particles.position = xyz
                fr.particles.image = image
                fr.particles.orientation = _quaternion_z(cf.theta).astype(np.float32)
                fr.particles.diameter = np.full(N, 2.0 * R0, dtype=np.float32)
                if polygons:
                    fr.particles.types = [f"cell{i}" for i in range(N)]
                    fr.particles.typeid = np.arange(N, dtype=np.uint32)
                    body = cell_contours(np.zeros((N, 2)), np.zeros(N), cf.a, cf.b, R0, K)
                    fr.particles.type_shapes = [{"type": "Polygon", "rounding_radius": 0.0,
                                                 "vertices": v.tolist()} for v in body]
                else:
                    fr.particles.types = ["cell"]
                    fr.particles.typeid = np.zeros(N, dtype=np.uint32)
                    fr.particles.type_shapes = [{"type": "Sphere", "diameter": 2.0 * R0}]
                for name, v in cf.per_cell().items():
                    v = np.asarray(v)
                    fr.log[f"particles/{name}"] = v.astype(np.float32) if v.dtype.kind == "f" else v
                fr.log["fcsweep/time"] = np.array([cf.time], dtype=np.float64)
                if n == 0:
                    fr.log.update(_gsd_parameters(traj.params))
                f.append(fr)
                bar.update(1)

    return atomic_write(out, write, fsync=True, interruptible=True)


# ------------------------------------------------------------------ VTK XML PolyData

_VTK_TYPES = {"Float64": np.float64, "Int64": np.int64, "UInt8": np.uint8}


def _vtk_type(arr: np.ndarray) -> str:
    if arr.dtype.kind == "f":
        return "Float64"
    if arr.dtype.kind == "b" or arr.dtype == np.uint8:
        return "UInt8"
    return "Int64"


def _data_array(name: str, values, *, binary: bool, components: int = 1, tuples: int | None = None,
                vtk_type: str | None = None) -> str:
    """One ``<DataArray>`` element: base64 of ``[UInt64 byte count][values]`` (VTK's
    inline binary layout, encoded as one stream) or ascii."""
    arr = np.asarray(values)
    vtk_type = vtk_type or _vtk_type(arr)
    arr = np.ascontiguousarray(arr, dtype=_VTK_TYPES[vtk_type]).ravel()
    attrs = f'type="{vtk_type}" Name={quoteattr(name)} NumberOfComponents="{components}"'
    if tuples is not None:
        attrs += f' NumberOfTuples="{tuples}"'
    if binary:
        raw = arr.astype(arr.dtype.newbyteorder("<"), copy=False).tobytes()
        text = base64.b64encode(np.uint64(len(raw)).astype("<u8").tobytes() + raw).decode("ascii")
        return f'<DataArray {attrs} format="binary">{text}</DataArray>\n'
    text = " ".join(map(repr, arr.tolist())) if arr.dtype.kind == "f" else " ".join(map(str, arr.tolist()))
    return f'<DataArray {attrs} format="ascii">{text}</DataArray>\n'


def periodic_copies(contours: np.ndarray, box) -> tuple[np.ndarray, np.ndarray]:
    """Contours with a shifted copy on every side of the box that a contour crosses.

    Returns
    -------
    contours : ndarray, shape (P, K, 2)
        The originals first, then the copies.
    owner : ndarray of int, shape (P,)
        Cell index of each contour.
    """
    box = np.asarray(box, dtype=float)
    lo, hi = contours.min(axis=1), contours.max(axis=1)
    out, owner = [contours], [np.arange(contours.shape[0])]
    for sx in (-1, 0, 1):
        for sy in (-1, 0, 1):
            if sx == sy == 0:
                continue
            s = np.array([sx, sy]) * box
            hit = np.flatnonzero(np.all(hi + s > 0, axis=1) & np.all(lo + s < box, axis=1))
            out.append(contours[hit] + s)
            owner.append(hit)
    return np.concatenate(out), np.concatenate(owner)


def polydata_xml(contours: np.ndarray, cell_data: dict, field_data: dict, *, binary: bool = True) -> str:
    """A VTK XML PolyData document with one closed polyline per contour.

    Parameters
    ----------
    contours : ndarray, shape (P, K, 2)
        Points of each polyline (z = 0); each line runs through its K points and back to
        the first.
    cell_data : dict of name -> ndarray, shape (P,) or (P, C)
    field_data : dict of name -> ndarray (one tuple each)
    binary : bool
        Base64 binary (default) or ascii data.
    """
    P, K, _ = contours.shape
    pts = np.zeros((P * K, 3))
    pts[:, :2] = contours.reshape(-1, 2)
    conn = np.concatenate([np.arange(P * K).reshape(P, K), (K * np.arange(P))[:, None]], axis=1)
    offsets = (K + 1) * np.arange(1, P + 1)
    parts = ['<?xml version="1.0"?>\n',
             '<VTKFile type="PolyData" version="1.0" byte_order="LittleEndian" header_type="UInt64">\n',
             "<PolyData>\n<FieldData>\n"]
    for name, v in field_data.items():
        v = np.atleast_1d(np.asarray(v))
        parts.append(_data_array(name, v, binary=binary, components=v.size, tuples=1))
    parts.append(f'</FieldData>\n<Piece NumberOfPoints="{P * K}" NumberOfVerts="0" NumberOfLines="{P}" '
                 f'NumberOfStrips="0" NumberOfPolys="0">\n<Points>\n')
    parts.append(_data_array("Points", pts, binary=binary, components=3, vtk_type="Float64"))
    parts.append("</Points>\n<Lines>\n")
    parts.append(_data_array("connectivity", conn, binary=binary, vtk_type="Int64"))
    parts.append(_data_array("offsets", offsets, binary=binary, vtk_type="Int64"))
    first = next(iter(cell_data), None)
    parts.append("</Lines>\n" + (f"<CellData Scalars={quoteattr(first)}>\n" if first else "<CellData>\n"))
    for name, v in cell_data.items():
        v = np.asarray(v)
        parts.append(_data_array(name, v, binary=binary, components=1 if v.ndim == 1 else v.shape[1]))
    parts.append("</CellData>\n</Piece>\n</PolyData>\n</VTKFile>\n")
    return "".join(parts)


def _write_text(path: Path, text: str) -> None:
    atomic_write(path, lambda tmp: tmp.write_text(text, encoding="ascii"))


def export_vtk(traj_path, out_dir, *, frames=None, unwrapped: bool = False, images: bool = False,
               binary: bool = True, stem: str = "cells", defects: bool = True, progress: bool = True) -> Path:
    """Write a trajectory (or some of its frames) as VTK PolyData files and a ParaView
    collection.

    Parameters
    ----------
    traj_path : path-like
        A ``trajectory.h5`` (or a running run's ``.partial``, or a run directory).
    out_dir : path-like
        Directory for ``<stem>_<frame>.vtp`` (frame = trajectory frame index, 6 digits) and
        ``<stem>.pvd``; created if missing.  Each file is written whole or not at all
        (:func:`fcsweep.io.sweepdir.atomic_write`) and the ``.pvd`` last: a failed or
        interrupted export leaves the complete ``.vtp`` files written so far beside the
        previous ``.pvd`` (if any), never a truncated file; export again to finish.
    frames : see :func:`parse_frames`
        Frames to export (default all).
    unwrapped : bool
        Contours around the unwrapped centroids instead of the wrapped ones.
    images : bool
        Also draw a periodic copy of each contour that crosses the box edge (CellData
        ``cell`` names its cell; ``copy`` is 1 for the copies), as a periodic snapshot
        looks; otherwise exactly one polyline per cell, in cell order.
    binary : bool
        Base64 binary data (default) or ascii.
    stem : str
        File name stem.
    defects : bool
        Include ``defect``, ``n_sides`` and ``cluster`` (see :func:`export_gsd`).
    progress : bool
        Show a progress bar (tqdm) on stderr.

    Returns
    -------
    Path
        The ``.pvd`` collection.
    """
    traj = _open(traj_path)
    idx = parse_frames(frames, traj.n_frames)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    remove_stale(out_dir, (f"{stem}*",))
    box = np.asarray(traj.box, dtype=float)
    R0 = float(traj.params.get("R0", 1.0))
    K = _contour_points(traj)
    entries = []
    with _progress(idx.size, "export vtk", progress) as bar:
        for cf in iter_frames(traj, idx, defects=defects):
            centre = cf.unwrapped(box) if unwrapped else cf.position
            contours = cell_contours(centre, cf.theta, cf.a, cf.b, R0, K)
            owner = np.arange(traj.n_cells)
            if images:
                contours, owner = periodic_copies(contours, box)
            data = {name: np.asarray(v)[owner] for name, v in cf.per_cell().items()}
            data["cell"] = owner.astype(np.int64)
            data["copy"] = (np.arange(owner.size) >= traj.n_cells).astype(np.uint8)
            centroid = np.zeros((owner.size, 3))
            centroid[:, :2] = centre[owner]
            data["centroid"] = centroid
            field = {"TimeValue": np.float64(cf.time), "step": np.int64(cf.step), "box": box}
            name = f"{stem}_{cf.index:06d}.vtp"
            _write_text(out_dir / name, polydata_xml(contours, data, field, binary=binary))
            entries.append((cf.time, name))
            bar.update(1)
    pvd = out_dir / f"{stem}.pvd"
    lines = ['<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">\n',
             "<Collection>\n"]
    lines += [f'<DataSet timestep="{t!r}" group="" part="0" file={quoteattr(n)}/>\n' for t, n in entries]
    lines.append("</Collection>\n</VTKFile>\n")
    _write_text(pvd, "".join(lines))
    return pvd


def export(traj_path, out, fmt: str, **kwargs) -> Path:
    """:func:`export_gsd` (``fmt="gsd"``, ``out`` a file) or :func:`export_vtk`
    (``fmt="vtk"``, ``out`` a directory); returns the file to open in a viewer."""
    if fmt == "gsd":
        return export_gsd(traj_path, out, **kwargs)
    if fmt == "vtk":
        return export_vtk(traj_path, out, **kwargs)
    raise ValueError(f"unknown export format {fmt!r}: choose one of {sorted(FORMATS)}")
