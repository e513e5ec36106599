"""VTK XML PolyData series of a trajectory (ParaView, VisIt, pyvista): one ``.vtp`` per
frame, each cell a closed polyline through its contour, and a ``.pvd`` collection.
Written with numpy only; see :mod:`fcsweep.results.export` for the per-cell quantities.
"""

from __future__ import annotations

import base64
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from fcsweep.io.failures import remove_stale
from fcsweep.io.sweepdir import atomic_write
from fcsweep.results.cells import (cell_contours, iter_frames, open_nonempty, parse_frames, progress_bar,
                                   run_confinement_of, traj_contour_points)

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


def periodic_axes(traj) -> tuple[bool, bool]:
    """Which axes of a trajectory's box are periodic: both, or those of its well or channel."""
    conf = run_confinement_of(traj)
    return (True, True) if conf is None else conf.periodic


def periodic_copies(contours: np.ndarray, box, periodic=(True, True)) -> tuple[np.ndarray, np.ndarray]:
    """Contours with a shifted copy on every side of the box that a contour crosses, along
    the periodic axes only (``periodic``: (x, y); a well has none, a channel x only: no
    copy across a wall).

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
    xs, ys = ((-1, 0, 1) if p else (0,) for p in periodic)
    for sx in xs:
        for sy in ys:
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
    traj = open_nonempty(traj_path)
    idx = parse_frames(frames, traj.n_frames)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    remove_stale(out_dir, (f"{stem}*",))
    box = np.asarray(traj.box, dtype=float)
    R0 = float(traj.params.get("R0", 1.0)) if traj.radii is None else traj.radii  # per-cell radii if sizes differ
    K = traj_contour_points(traj)
    entries = []
    with progress_bar(idx.size, "export vtk", progress) as bar:
        for cf in iter_frames(traj, idx, defects=defects):
            centre = cf.unwrapped(box) if unwrapped else cf.position
            contours = cell_contours(centre, cf.theta, cf.a, cf.b, R0, K)
            owner = np.arange(traj.n_cells)
            if images:  # no copy across the wall of a well or channel
                contours, owner = periodic_copies(contours, box, periodic_axes(traj))
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
