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

A confined run (a well or channel) is exported in its host box, which holds the walls with
an empty margin: no copy is made across a wall (VTK ``images`` copies along a channel's x
only), and ``defect``, ``n_sides`` and ``cluster`` are those the analysis counts
(:mod:`fcsweep.analysis.confined`: certain sides, at least 2a from the walls). GSD knows
periodic boxes only: its box is the host box, and the image counts of a well stay 0.

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

import json
from pathlib import Path

import numpy as np

from fcsweep.io.failures import remove_stale
from fcsweep.io.sweepdir import atomic_write
from fcsweep.results.cells import (BLOCK_BYTES, DEFAULT_CONTOUR_POINTS, FORMATS, CellFrame, traj_contour_points,  # noqa: F401
                                   open_nonempty, progress_bar, cell_contours, cluster_ids, iter_frames, parse_frames)
from fcsweep.results.vtk import export_vtk, periodic_copies, polydata_xml  # noqa: F401


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
    fcsweep.io.trajectory.TrajectoryError
        If the trajectory cannot be read.
    ValueError
        For a bad ``frames`` spec.
    """
    try:
        import gsd.hoomd
    except ImportError as exc:
        raise ImportError("GSD export needs the gsd package: pip install gsd") from exc
    traj = open_nonempty(traj_path)
    idx = parse_frames(frames, traj.n_frames)
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    box = np.asarray(traj.box, dtype=float)
    half = box / 2.0
    R0 = float(traj.params.get("R0", 1.0))
    radii = traj.radii  # per-cell radii when sizes differ
    K = traj_contour_points(traj)
    N = traj.n_cells
    remove_stale(out.parent, (out.name,))

    def write(tmp: Path) -> None:
        with gsd.hoomd.open(str(tmp), "w") as f, progress_bar(idx.size, "export gsd", progress) as bar:
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
                fr.particles.diameter = (np.full(N, 2.0 * R0) if radii is None else 2.0 * radii).astype(np.float32)
                if polygons:
                    fr.particles.types = [f"cell{i}" for i in range(N)]
                    fr.particles.typeid = np.arange(N, dtype=np.uint32)
                    body = cell_contours(np.zeros((N, 2)), np.zeros(N), cf.a, cf.b, R0 if radii is None else radii, K)
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


def export(traj_path, out, fmt: str, **kwargs) -> Path:
    """:func:`export_gsd` (``fmt="gsd"``, ``out`` a file) or :func:`export_vtk`
    (``fmt="vtk"``, ``out`` a directory); returns the file to open in a viewer."""
    if fmt == "gsd":
        return export_gsd(traj_path, out, **kwargs)
    if fmt == "vtk":
        return export_vtk(traj_path, out, **kwargs)
    raise ValueError(f"unknown export format {fmt!r}: choose one of {sorted(FORMATS)}")
