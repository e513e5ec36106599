"""H5MD 1.1 trajectory files of one run (write in batches, truncate, read back).

Layout (see ``results_schema.md``)::

    /h5md                       attrs version=[1, 1]
      creator                   attrs name="fcsweep", version=<package version>
      author                    attrs name=<user>
      modules/units             attrs version=[1, 0], system="SI"-free reduced units
    /particles/cells/box        attrs dimension=2, boundary=["periodic", "periodic"] (a well:
                                ["none", "none"], a channel: ["periodic", "none"])
      edges                     (2,) float64  (Lx, Ly) (the host box of a well or channel)
    /particles/cells/R0         (N,) float64  per-cell radii R0,i, only when sizes differ
    /particles/cells/<field>/{step (T,) int64, time (T,) float64, value (T, N, ...)}
    /observables/projections/{step, time, value (T,) int64}
    /parameters                 attrs: every model/run parameter, seed, run_id, ...

The writer keeps the file *closed* between batches: frames are appended in one
open-append-close step (normally at a checkpoint), so a process killed at an arbitrary
moment almost always leaves a cleanly closed file, and the checkpoint records how many of
its frames are valid.  HDF5's own file locking is switched off (``locking=False``): runs
are protected by :mod:`fcsweep.io.locks`, and HDF5 locks fail on some network file systems.

Every session that modifies an existing file (append, truncate, attributes) is announced
in ``<file>.seq``, a counter that is odd while the session runs (:func:`write_count`): a
reader that finds the same even count before and after its read knows no writer touched
the file meanwhile.  Without it a reader can get a stale chunk index from an open during
an append and read, with valid checksums, another frame's chunk in the place of its own.
"""

from __future__ import annotations

import contextlib
import getpass
import json
import os
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import h5py
import numpy as np

from fcsweep.io.schema import (
    FIELD_LAYOUT,
    H5MD_VERSION,
    LENGTH_UNIT,
    OBSERVABLES,
    PARAMETERS,
    PARTICLES,
    TIME_UNIT,
    UNIT_SYSTEM,
)

__all__ = [
    "create_trajectory",
    "box_boundary",
    "append_frames",
    "truncate_frames",
    "frame_count",
    "set_attrs",
    "read_parameters",
    "open_h5",
    "fsync_path",
    "verify_trajectory",
    "repack",
    "write_count",
    "seq_path",
]

#: Frames read at a time while verifying checksums (bounded memory for big files).
_VERIFY_BYTES = 64 << 20


#: What ``/particles/cells`` holds besides its time series: the box and the per-cell radii.
STATIC = ("box", "R0")


def open_h5(path, mode: str = "r") -> h5py.File:
    """Open an HDF5 file without HDF5's own file locking (our run locks protect writers).

    Files are created in the HDF5 1.8 format (``libver="v108"``: object headers carry
    checksums; unlike the 1.10 format, a writer killed with the file open leaves no
    "file is already open for write" flag behind)."""
    kwargs = {"libver": ("v108", "v108")} if mode in ("w", "x", "w-") else {}
    try:
        return h5py.File(path, mode, locking=False, **kwargs)
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


def _vlen_str(attrs, name: str, value) -> None:
    """Write a scalar or 1-d variable-length string attribute, ASCII where possible
    (H5MD 1.1 asks for variable-length strings; the units module for ASCII ones)."""
    values = [value] if isinstance(value, str) else list(value)
    ascii_ok = all(v.isascii() for v in values)
    dt = h5py.string_dtype("ascii" if ascii_ok else "utf-8")
    data = [v.encode("ascii" if ascii_ok else "utf-8") for v in values]
    if isinstance(value, str):
        attrs.create(name, data[0], dtype=dt)
    else:
        attrs.create(name, np.array(data, dtype=object), shape=(len(data),), dtype=dt)


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
    frames_per_chunk: int | None = None,
    radii: Sequence[float] | None = None,
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
        Time step; stored as attribute of the ``time`` dataset.
    frames_per_chunk : int, optional
        Frames per HDF5 chunk of the ``value`` datasets (the frames one checkpoint adds,
        so that appends write whole chunks); capped at 4 MiB per chunk.
    radii : sequence of float, optional
        Per-cell radii R0,i (cell size differences), written as the time-independent
        dataset ``particles/cells/R0``; nothing is written for equal cells.

    Notes
    -----
    Every dataset carries a Fletcher-32 checksum (:func:`verify_trajectory`).  All time
    series are sampled together, so ``step`` and ``time`` exist once, in ``position``,
    and every other series holds hard links to them (H5MD 1.1 requires it of ``image``).
    The file uses the HDF5 1.8 format (``libver="v108"``), whose object headers carry
    checksums too.
    """
    copts = _storage_options(compression, compression_level)
    with open_h5(path, "w") as f:
        _write_header(f, creator_version)
        cells = f.require_group(PARTICLES)
        _write_box(cells, box, box_boundary(parameters.get("boundary", "periodic")))
        if radii is not None:
            r = cells.create_dataset("R0", data=np.asarray(radii, dtype=np.float64), fletcher32=True)
            r.attrs["unit"] = "R0"
            _vlen_str(r.attrs, "description", "radius R0,i of each cell (its area is pi R0,i^2), mean R0")
        clock: dict[str, h5py.Dataset] = {}
        for name in sorted(fields, key=lambda n: n != "position"):  # position first: owns step/time
            dtype, _, unit, desc = FIELD_LAYOUT[name]
            _create_series(cells.create_group(name), clock, _trailing(name, n_cells, modes_width), dtype, unit, desc,
                           dt=dt, frames_per_chunk=frames_per_chunk, copts=copts)
        _create_series(f.require_group(OBSERVABLES).create_group("projections"), clock, (), "int64", None,
                       "cumulative number of shape projections back into the admissible set",
                       dt=dt, frames_per_chunk=frames_per_chunk, copts=copts)
        par = f.require_group(PARAMETERS)
        for k, v in parameters.items():
            par.attrs[k] = _attr_value(v)
    fsync_path(path)


def _storage_options(compression: str, level: int) -> dict[str, Any]:
    """h5py dataset options of the ``value`` series: Fletcher-32 and the compression."""
    comp = None if compression == "none" else compression
    copts: dict[str, Any] = {"fletcher32": True}
    if comp == "gzip":
        copts.update(compression="gzip", compression_opts=int(level), shuffle=True)
    elif comp == "lzf":
        copts.update(compression="lzf", shuffle=True)
    return copts


def _write_header(f: h5py.File, creator_version: str) -> None:
    """The ``/h5md`` group: version, creator, author and the units module."""
    h5md = f.create_group("h5md")
    h5md.attrs["version"] = np.array(H5MD_VERSION, dtype=np.int32)
    creator = h5md.create_group("creator")
    _vlen_str(creator.attrs, "name", "fcsweep")
    _vlen_str(creator.attrs, "version", str(creator_version))
    author = h5md.create_group("author")
    try:
        user = getpass.getuser()
    except Exception:  # noqa: BLE001 - no user name in some batch environments
        user = "fcsweep"
    _vlen_str(author.attrs, "name", user)
    units = h5md.create_group("modules").create_group("units")
    units.attrs["version"] = np.array([1, 0], dtype=np.int32)
    _vlen_str(units.attrs, "system", UNIT_SYSTEM)


def box_boundary(boundary: str) -> list[str]:
    """The H5MD ``boundary`` attribute of the box for the run parameter ``boundary``: both
    axes ``periodic`` in the periodic box; ``none`` across a wall (a well: both axes; a
    channel: y, its x stays periodic).  The ``edges`` are then those of the host box, which
    holds the well or channel with an empty margin (:mod:`fcsweep.model.confinement`)."""
    return {"well": ["none", "none"], "channel": ["periodic", "none"]}.get(str(boundary), ["periodic", "periodic"])


def _write_box(cells: h5py.Group, box: Sequence[float], boundary=("periodic", "periodic")) -> None:
    """The box of the particle group: ``box/edges`` (Lx, Ly) and which axes are periodic."""
    boxg = cells.create_group("box")
    boxg.attrs["dimension"] = np.int32(2)
    _vlen_str(boxg.attrs, "boundary", list(boundary))
    edges = boxg.create_dataset("edges", data=np.asarray(box, dtype=np.float64), fletcher32=True)
    _vlen_str(edges.attrs, "unit", LENGTH_UNIT)


def _create_series(group: h5py.Group, clock: dict, value_shape, dtype, unit: str | None, description: str, *,
                   dt: float, frames_per_chunk: int | None, copts: dict) -> None:
    """One empty H5MD time series in ``group``: the first creates ``step`` and ``time``
    (kept in ``clock``), the later ones hard-link them (series sampled together)."""
    frame_bytes = int(np.prod(value_shape, dtype=np.int64)) * np.dtype(dtype).itemsize
    cap = max(1, (4 << 20) // max(frame_bytes, 1))
    chunk_t = int(min(frames_per_chunk, cap)) if frames_per_chunk else int(max(1, min(256, cap // 16)))
    if not clock:
        clock["step"] = group.create_dataset(
            "step", shape=(0,), maxshape=(None,), dtype=np.int64, chunks=(1024,), fletcher32=True)
        clock["time"] = group.create_dataset(
            "time", shape=(0,), maxshape=(None,), dtype=np.float64, chunks=(1024,), fletcher32=True)
        _vlen_str(clock["time"].attrs, "unit", TIME_UNIT)
        clock["time"].attrs["dt"] = float(dt)
    else:  # H5MD: series sampled together hard-link step and time
        group["step"] = clock["step"]
        group["time"] = clock["time"]
    value = group.create_dataset(
        "value",
        shape=(0, *value_shape),
        maxshape=(None, *value_shape),
        dtype=dtype,
        chunks=(max(1, chunk_t), *value_shape),
        **copts,
    )
    if unit is not None:
        _vlen_str(value.attrs, "unit", unit)
    _vlen_str(value.attrs, "description", description)


def _datasets(f: h5py.File) -> list[h5py.Dataset]:
    """Every time-series dataset once (hard links counted once)."""
    seen, out = set(), []
    groups = [g for name, g in f[PARTICLES].items() if name not in STATIC] + [f[OBSERVABLES]["projections"]]
    for g in groups:
        for ds in g.values():
            if ds.id not in seen:  # ObjectIDs of one object compare equal
                seen.add(ds.id)
                out.append(ds)
    return out


def _series(f: h5py.File) -> dict[str, h5py.Group]:
    out = {name: g for name, g in f[PARTICLES].items() if name not in STATIC}
    out["projections"] = f[OBSERVABLES]["projections"]
    return out


def seq_path(path) -> Path:
    """The write counter beside a trajectory file (``<file>.seq``)."""
    return Path(f"{os.fspath(path)}.seq")


def write_count(path) -> int:
    """Modifying sessions begun on ``path`` so far (0 if none), odd while one runs."""
    try:
        return int(seq_path(path).read_text())
    except (OSError, ValueError):
        return 0


def _put_count(path, n: int) -> None:
    seq = seq_path(path)
    tmp = seq.with_name(f".{seq.name}.{os.getpid()}.tmp")
    tmp.write_text(str(n))
    os.replace(tmp, seq)  # readers see the old count or the new one


@contextlib.contextmanager
def _modifying(path):
    """Announce a writing session to live readers: odd count during, next even after."""
    n = write_count(path)
    n += 1 if n % 2 == 0 else 2  # a writer that died mid-session left it odd
    _put_count(path, n)
    try:
        yield
    finally:
        _put_count(path, n + 1)


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
    with _modifying(path), open_h5(path, "r+") as f:
        groups = _series(f)
        datasets = _datasets(f)
        n0 = groups["position"]["step"].shape[0]
        if expected_start is not None:
            if n0 < expected_start:
                raise RuntimeError(f"{path}: has {n0} frames, expected at least {expected_start}")
            n0 = expected_start
        k = len(frames)
        if k == 0:
            return n0
        for ds in datasets:
            ds.resize(n0 + k, axis=0)
        if after_resize is not None:
            after_resize()
        for name, g in groups.items():
            data = np.stack([np.asarray(fr[name]) for fr in frames]).astype(g["value"].dtype, copy=False)
            g["value"][n0:] = data
        # step and time last: a frame whose step is set has its data written
        groups["position"]["time"][n0:] = np.array([fr["time"] for fr in frames], dtype=np.float64)
        groups["position"]["step"][n0:] = np.array([fr["step"] for fr in frames], dtype=np.int64)
        n = n0 + k
    fsync_path(path)
    return n


def truncate_frames(path, n: int) -> None:
    """Shrink every time series to its first ``n`` frames (frames after a checkpoint)."""
    with _modifying(path), open_h5(path, "r+") as f:
        for ds in _datasets(f):
            if ds.shape[0] != n:
                ds.resize(n, axis=0)
    fsync_path(path)


def set_attrs(path, group: str, attrs: Mapping[str, Any]) -> None:
    """Set attributes of one group (e.g. ``/parameters`` ``complete = 1``)."""
    with _modifying(path), open_h5(path, "r+") as f:
        g = f.require_group(group)
        for k, v in attrs.items():
            g.attrs[k] = _attr_value(v)
    fsync_path(path)


def read_parameters(path) -> dict[str, Any]:
    """Attributes of ``/parameters`` as a plain dict (JSON strings left as strings)."""
    with open_h5(path, "r") as f:
        return {k: (v.item() if isinstance(v, np.generic) else v) for k, v in f[PARAMETERS].attrs.items()}


def verify_trajectory(path, n_frames: int | None = None, *, complete: bool = True) -> str | None:
    """Check a trajectory end to end; ``None`` if it is sound, else what is wrong.

    Every dataset is read in full, so the Fletcher-32 checksum of every chunk is
    verified (and the checksums of the object headers); a truncated
    or overwritten file fails to open or to read.  Also checked: all time series have
    the same number of frames (``n_frames`` if given), the steps increase strictly, and
    ``/parameters`` says ``complete = 1`` (if ``complete``).

    Parameters
    ----------
    path : path-like
    n_frames : int, optional
        Expected number of frames.
    complete : bool
        Require the ``complete`` flag of a finished trajectory.
    """
    try:
        with open_h5(path, "r") as f:
            datasets: list[h5py.Dataset] = []
            f.visititems(lambda _n, obj: datasets.append(obj) if isinstance(obj, h5py.Dataset) else None)
            for ds in datasets:
                if ds.shape == () or ds.size == 0:
                    ds[()]
                    continue
                row = max(1, int(np.prod(ds.shape[1:], dtype=np.int64)) * ds.dtype.itemsize)
                step = max(1, _VERIFY_BYTES // row)
                for i in range(0, ds.shape[0], step):
                    ds[i:i + step]
            dict(f[PARAMETERS].attrs)
            steps = f[PARTICLES]["position"]["step"][()]
            n = int(steps.shape[0])
            if n_frames is not None and n != n_frames:
                return f"{n} frames, expected {n_frames}"
            short = [ds.name for ds in _datasets(f) if ds.shape[0] != n]
            if short:
                return f"time series of unequal length: {', '.join(short)} differ from position/step ({n})"
            if n > 1 and not np.all(np.diff(steps) > 0):
                return "steps do not increase"
            if complete and not int(f[PARAMETERS].attrs.get("complete", 0)):
                return "not marked complete"
    except Exception as exc:  # noqa: BLE001 - any failure to read is damage
        return f"unreadable ({type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''})"
    return None


def repack(src, dst) -> None:
    """Copy a trajectory into a fresh file, dropping the space that appends left unused.

    Datasets are copied chunk for chunk (filters and chunking kept); hard links stay
    hard links; attributes are copied.  ``dst`` is fsynced.
    """
    copied: dict[Any, str] = {}
    with open_h5(src, "r") as fin, open_h5(dst, "w") as fout:
        _copy_attrs(fin, fout)

        def walk(gin: h5py.Group, gout: h5py.Group) -> None:
            for name, obj in gin.items():
                if isinstance(obj, h5py.Group):
                    sub = gout.create_group(name)
                    _copy_attrs(obj, sub)
                    walk(obj, sub)
                elif obj.id in copied:
                    gout[name] = gout.file[copied[obj.id]]
                else:
                    fin.copy(obj, gout, name=name)
                    copied[obj.id] = gout[name].name

        walk(fin, fout)
    fsync_path(dst)


def _copy_attrs(src: h5py.HLObject, dst: h5py.HLObject) -> None:
    """Copy attributes with their exact HDF5 datatypes (e.g. variable-length ASCII)."""
    for name in src.attrs:
        tid = src.attrs.get_id(name).get_type()
        dtype = src.attrs.get_id(name).dtype
        if tid.get_class() == h5py.h5t.STRING:
            cset = "ascii" if tid.get_cset() == h5py.h5t.CSET_ASCII else "utf-8"
            dtype = h5py.string_dtype(cset, None if tid.is_variable_str() else tid.get_size())
        value = src.attrs[name]
        if isinstance(value, str):
            value = value.encode("utf-8")
        elif isinstance(value, np.ndarray) and value.dtype == object:
            value = np.array([v.encode("utf-8") if isinstance(v, str) else v for v in value], dtype=object)
        dst.attrs.create(name, value, dtype=dtype)
