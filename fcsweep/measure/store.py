"""The per-cell results of a movie, frame after frame, on disk: what keeps the memory of
``fcsweep measure`` independent of the number of frames.

Each frame's cells are appended to one raw file per variable in a scratch directory
(:class:`CellSpool`); the ``time`` x ``cell`` arrays of the dataset are assembled from it at
the end, a block of frames at a time (:meth:`CellSpool.dense`), and written to
``measure.nc`` variable by variable (:func:`append_cell_variables`).  This module and
:mod:`fcsweep.measure.readers` are the only places of the measure package that touch files.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

__all__ = ["CellSpool", "append_cell_variables", "BLOCK_BYTES", "READ_CELLS"]

#: Bytes of one assembled block of a ``time`` x ``cell`` (x ``mode``) variable while it is
#: written: frames are taken in blocks that stay below this.
BLOCK_BYTES = 16 << 20
#: Values read from the spool at once while a block is assembled.
READ_CELLS = 1 << 16


class CellSpool:
    """Append-only store of per-cell arrays, frame by frame, in a temporary directory.

    Parameters
    ----------
    fields : dict
        ``name -> (dtype, tail)``: the dtype stored and the trailing shape of one cell's
        value (``()`` or ``(modes,)``).
    directory : path-like, optional
        Where the temporary directory is made (default: the system's).

    Use as a context manager; the files are removed on exit.
    """

    def __init__(self, fields: dict, directory=None):
        self.fields = {k: (np.dtype(d), tuple(t)) for k, (d, t) in fields.items()}
        self._tmp = tempfile.TemporaryDirectory(prefix=".fcsweep-measure-", dir=directory)
        root = Path(self._tmp.name)
        self._files = {k: open(root / f"{k}.bin", "w+b") for k in (*self.fields, "_index")}
        self.counts: list[int] = []

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def close(self) -> None:
        """Close and remove the files."""
        for fh in self._files.values():
            fh.close()
        self._tmp.cleanup()

    @property
    def frames(self) -> int:
        """Frames appended so far."""
        return len(self.counts)

    def append(self, cells: dict, index: np.ndarray) -> None:
        """Append one frame: ``cells[name]`` of shape ``(n,) + tail`` for every field, and the
        cell (track) index of each of the ``n`` cells."""
        index = np.asarray(index, dtype=np.int64)
        for name, (dtype, tail) in self.fields.items():
            value = np.asarray(cells[name]).astype(dtype, copy=False)
            if value.shape != (index.size,) + tail:
                raise ValueError(f"{name}: shape {value.shape}, expected {(index.size,) + tail}")
            value.tofile(self._files[name])
        index.tofile(self._files["_index"])
        self.counts.append(int(index.size))

    def _read(self, name: str, start: int, count: int, dtype, tail) -> np.ndarray:
        fh = self._files[name]
        fh.flush()
        per = int(np.prod(tail, dtype=np.int64))
        fh.seek(start * per * dtype.itemsize)
        return np.fromfile(fh, dtype=dtype, count=count * per).reshape((count,) + tail)

    def dense(self, name: str, ncell: int, fill, dtype, frames: slice = slice(None)) -> np.ndarray:
        """The ``(frames, ncell) + tail`` array of ``name``, ``fill`` where a cell is absent.

        Parameters
        ----------
        name : str
        ncell : int
            Cells (tracks) of the whole movie.
        fill : scalar
        dtype : dtype
            Of the result.
        frames : slice
            A contiguous range of frames (step 1).
        """
        k0, k1, _ = frames.indices(self.frames)
        stored, tail = self.fields[name]
        offsets = np.concatenate([[0], np.cumsum(self.counts, dtype=np.int64)])
        out = np.full((max(k1 - k0, 0), ncell) + tail, fill, dtype=dtype)
        per = max(1, int(np.prod(tail, dtype=np.int64)))
        a = k0
        while a < k1:  # the records read at once stay under READ_CELLS values
            b = max(a + 1, int(np.searchsorted(offsets, offsets[a] + READ_CELLS // per, side="right")) - 1)
            b = min(b, k1)
            start, count = int(offsets[a]), int(offsets[b] - offsets[a])
            if count:
                rows = np.repeat(np.arange(a - k0, b - k0), self.counts[a:b])
                idx = self._read("_index", start, count, np.dtype(np.int64), ())
                out[rows, idx] = self._read(name, start, count, stored, tail)
            a = b
        return out

    def blocks(self, ncell: int, tail=()):
        """Slices of frames whose ``(frames, ncell) + tail`` float64 block stays under
        :data:`BLOCK_BYTES`."""
        per = max(1, ncell * int(np.prod(tail, dtype=np.int64)) * 8)
        step = max(1, BLOCK_BYTES // per)
        return [slice(k, min(k + step, self.frames)) for k in range(0, self.frames, step)]


def append_cell_variables(path, spool: CellSpool, ncell: int, variables: dict) -> None:
    """Add the ``time`` x ``cell`` (x ``mode``) variables to a NetCDF4 file that has the
    ``time`` (and ``mode``) dimensions, a block of frames at a time.

    Parameters
    ----------
    path : path-like
        The file (written by xarray, which made its other variables).
    spool : CellSpool
    ncell : int
    variables : dict
        ``name -> (dims, dtype, fill, attrs)``: as xarray writes them, a float variable with
        ``_FillValue`` NaN, an integer one without ``_FillValue`` (its ``fill`` is a value).
    """
    import netCDF4

    with netCDF4.Dataset(path, "a") as nc:
        nc.createDimension("cell", ncell)
        for name, (dims, dtype, fill, attrs) in variables.items():
            dtype = np.dtype(dtype)
            var = nc.createVariable(name, dtype, dims, fill_value=np.nan if dtype.kind == "f" else None)
            var.setncatts(attrs)
            tail = spool.fields[name][1]
            for block in spool.blocks(ncell, tail):
                var[block] = spool.dense(name, ncell, fill, dtype, block)
