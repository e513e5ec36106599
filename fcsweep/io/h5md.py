"""H5MD 1.1 trajectory files of one run (write in batches, truncate, read back).

Layout (see ``results_schema.md``)::

    /h5md                       attrs version=[1, 1]
      creator                   attrs name="fcsweep", version=<package version>
      author                    attrs name=<user>
      modules/units             attrs version=[1, 0], system="SI"-free reduced units
    /particles/cells/box        attrs dimension=2, boundary=["periodic", "periodic"]
      edges                     (2,) float64  (Lx, Ly)
    /particles/cells/<field>/{step (T,) int64, time (T,) float64, value (T, N, ...)}
    /observables/projections/{step, time, value (T,) int64}
    /parameters                 attrs: every model/run parameter, seed, run_id, ...

The writer keeps the file *closed* between batches: frames are appended in one
open-append-close step (normally at a checkpoint), so a process killed at an arbitrary
moment almost always leaves a cleanly closed file, and the checkpoint records how many of
its frames are valid.  HDF5's own file locking is switched off (``locking=False``): runs
are protected by :mod:`fcsweep.io.locks`, and HDF5 locks fail on some network file systems.
"""

from __future__ import annotations

import getpass
import json
import os
from typing import Any, Callable, Mapping, Sequence

import h5py
import numpy as np

from fcsweep.io.schema import FIELD_LAYOUT, H5MD_VERSION, OBSERVABLES, PARAMETERS, PARTICLES

__all__ = [
    "create_trajectory",
    "append_frames",
    "truncate_frames",
    "frame_count",
    "set_attrs",
    "read_parameters",
    "open_h5",
    "fsync_path",
]


def open_h5(path, mode: str = "r") -> h5py.File:
    """Open an HDF5 file without HDF5's own file locking (our run locks protect writers)."""
    try:
        return h5py.File(path, mode, locking=False)
    except TypeError:  # pragma: no cover - very old h5py
        return h5py.File(path, mode)


def fsync_path(path) -> None:
    """Flush a file's data to stable storage (survives a node crash, not only SIGKILL)."""
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _trailing(field: str, n_cells: int, width: int) -> tuple[int, ...]:
    kind = FIELD_LAYOUT[field][1]
    if kind == "2":
        return (n_cells, 2)
    if kind == "modes":
        return (n_cells, width)
    return (n_cells,)


def _attr_value(v: Any) -> Any:
    if isinstance(v, (bool, np.bool_)):
        return np.int8(v)
    if isinstance(v, (int, np.integer)):
        return np.int64(v)
    if isinstance(v, (float, np.floating)):
        return np.float64(v)
    if isinstance(v, str):
        return v
    return json.dumps(v)


def create_trajectory(
    path,
    *,
    n_cells: int,
    box: Sequence[float],
    modes_width: int,
    fields: Sequence[str],
    parameters: Mapping[str, Any],
    dt: float,
    compression: str = "gzip",
    compression_level: int = 4,
    creator_version: str = "unknown",
) -> None:
    """Create an empty H5MD trajectory (all time series with 0 frames) and close it.

    Parameters
    ----------
    path : path-like
        File to create (overwritten).
    n_cells, box, modes_width
        N, (Lx, Ly) and the width M-1 of the shape-mode arrays.
    fields : sequence of str
        Per-cell time series to store (names of :data:`FIELD_LAYOUT`).
    parameters : mapping
        Written as attributes of ``/parameters`` (non-scalars as JSON strings).
    dt : float
        Time step; stored as attribute of every ``time`` dataset.
    """
    comp = None if compression == "none" else compression
    copts = {}
    if comp == "gzip":
        copts = {"compression": "gzip", "compression_opts": int(compression_level), "shuffle": True}
    elif comp == "lzf":
        copts = {"compression": "lzf", "shuffle": True}
    with open_h5(path, "w") as f:
        h5md = f.create_group("h5md")
        h5md.attrs["version"] = np.array(H5MD_VERSION, dtype=np.int32)
        creator = h5md.create_group("creator")
        creator.attrs["name"] = "fcsweep"
        creator.attrs["version"] = str(creator_version)
        author = h5md.create_group("author")
        try:
            author.attrs["name"] = getpass.getuser()
        except Exception:  # noqa: BLE001 - no user name in some batch environments
            author.attrs["name"] = "fcsweep"
        units = h5md.create_group("modules").create_group("units")
        units.attrs["version"] = np.array([1, 0], dtype=np.int32)
        units.attrs["system"] = "reduced: length R0, time 1/mobility (see results_schema.md)"

        cells = f.require_group(PARTICLES)
        boxg = cells.create_group("box")
        boxg.attrs["dimension"] = np.int32(2)
        boxg.attrs["boundary"] = np.array([b"periodic", b"periodic"], dtype="S8")
        edges = boxg.create_dataset("edges", data=np.asarray(box, dtype=np.float64))
        edges.attrs["unit"] = "R0"

        def series(group: h5py.Group, value_shape, dtype, unit: str, description: str):
            frame_bytes = int(np.prod(value_shape, dtype=np.int64)) * np.dtype(dtype).itemsize
            chunk_t = int(max(1, min(256, (1 << 18) // max(frame_bytes, 1))))
            step = group.create_dataset(
                "step", shape=(0,), maxshape=(None,), dtype=np.int64, chunks=(256,)
            )
            time = group.create_dataset(
                "time", shape=(0,), maxshape=(None,), dtype=np.float64, chunks=(256,)
            )
            time.attrs["unit"] = "1/mobility"
            time.attrs["dt"] = float(dt)
            step.attrs["description"] = "integration step of each frame"
            value = group.create_dataset(
                "value",
                shape=(0, *value_shape),
                maxshape=(None, *value_shape),
                dtype=dtype,
                chunks=(chunk_t, *value_shape),
                **copts,
            )
            value.attrs["unit"] = unit
            value.attrs["description"] = description

        for name in fields:
            dtype, _, unit, desc = FIELD_LAYOUT[name]
            series(cells.create_group(name), _trailing(name, n_cells, modes_width), dtype, unit, desc)
        obs = f.require_group(OBSERVABLES)
        series(
            obs.create_group("projections"),
            (),
            "int64",
            "1",
            "cumulative number of shape projections back into the admissible set",
        )
        par = f.require_group(PARAMETERS)
        for k, v in parameters.items():
            par.attrs[k] = _attr_value(v)
    fsync_path(path)


def _series(f: h5py.File) -> dict[str, h5py.Group]:
    out = {name: g for name, g in f[PARTICLES].items() if name != "box"}
    out["projections"] = f[OBSERVABLES]["projections"]
    return out


def frame_count(path) -> int:
    """Number of frames in a trajectory (length of the position time series)."""
    with open_h5(path, "r") as f:
        return int(f[PARTICLES]["position"]["step"].shape[0])


def append_frames(
    path,
    frames: Sequence[Mapping[str, Any]],
    *,
    expected_start: int | None = None,
    after_resize: Callable[[], None] | None = None,
) -> int:
    """Append frames to every time series in one open-append-close step.

    Parameters
    ----------
    frames : sequence of dict
        Each with ``step``, ``time``, ``projections`` and one array per stored field.
    expected_start : int, optional
        Frame count the file must have before the append (datasets are truncated to it
        if longer; a shorter file raises ``RuntimeError``).
    after_resize : callable, optional
        Called after the datasets are grown and before data are written (test hook).

    Returns
    -------
    int
        Frame count after the append.
    """
    with open_h5(path, "r+") as f:
        groups = _series(f)
        n0 = groups["position"]["step"].shape[0]
        if expected_start is not None:
            if n0 < expected_start:
                raise RuntimeError(f"{path}: has {n0} frames, expected at least {expected_start}")
            n0 = expected_start
        k = len(frames)
        if k == 0:
            return n0
        for g in groups.values():
            for ds in g.values():
                ds.resize(n0 + k, axis=0)
        if after_resize is not None:
            after_resize()
        steps = np.array([fr["step"] for fr in frames], dtype=np.int64)
        times = np.array([fr["time"] for fr in frames], dtype=np.float64)
        for name, g in groups.items():
            g["step"][n0:] = steps
            g["time"][n0:] = times
            data = np.stack([np.asarray(fr[name]) for fr in frames]).astype(g["value"].dtype, copy=False)
            g["value"][n0:] = data
        n = n0 + k
    fsync_path(path)
    return n


def truncate_frames(path, n: int) -> None:
    """Shrink every time series to its first ``n`` frames (frames after a checkpoint)."""
    with open_h5(path, "r+") as f:
        for g in _series(f).values():
            for ds in g.values():
                if ds.shape[0] != n:
                    ds.resize(n, axis=0)
    fsync_path(path)


def set_attrs(path, group: str, attrs: Mapping[str, Any]) -> None:
    """Set attributes of one group (e.g. ``/parameters`` ``complete = 1``)."""
    with open_h5(path, "r+") as f:
        g = f.require_group(group)
        for k, v in attrs.items():
            g.attrs[k] = _attr_value(v)
    fsync_path(path)


def read_parameters(path) -> dict[str, Any]:
    """Attributes of ``/parameters`` as a plain dict (JSON strings left as strings)."""
    with open_h5(path, "r") as f:
        return {k: (v.item() if isinstance(v, np.generic) else v) for k, v in f[PARAMETERS].attrs.items()}
