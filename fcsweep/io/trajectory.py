"""Read one H5MD trajectory of the contract layout (the only file reader of analysis).

Finished runs are read from ``trajectory.h5``; a running run's ``trajectory.h5.partial``
is read up to the frames its last checkpoint covers (see :func:`open_trajectory`).

``/particles/cells/{position,image,theta,shape_a,shape_b}/{step,time,value}``,
``/particles/cells/box/edges`` and the attributes of ``/parameters``.
"""

from __future__ import annotations

import time as _time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from fcsweep.io import schema
from fcsweep.io.h5md import STATIC, write_count
from fcsweep.io.rundir import RunDirectory
from fcsweep.io.schema import PARAMETERS
from fcsweep.io.schema import PARTICLES as CELLS


class TrajectoryError(RuntimeError):
    """A trajectory file that cannot be analysed; the message says why."""


def _plain(v):
    if isinstance(v, bytes):
        return v.decode()
    if isinstance(v, np.generic):
        return v.item()
    if isinstance(v, np.ndarray):
        return v.tolist()
    return v


@dataclass
class Trajectory:
    """Frames of one run held in memory (or a selection of them).

    Attributes
    ----------
    path : Path
    params : dict
        Attributes of ``/parameters`` (JSON strings left as strings).
    box : ndarray, shape (2,)
    step, time : ndarray, shape (T,)
        Of all frames in the file -- or, for a running run, of the frames its last
        checkpoint covers (``live``).
    fields : tuple of str
        Stored per-cell time series.
    live : bool
        ``path`` is the ``trajectory.h5.partial`` of a running run; reads are limited to
        the ``T`` checkpointed frames and retried while the writer is mid-append.
    """

    path: Path
    params: dict
    box: np.ndarray
    step: np.ndarray
    time: np.ndarray
    fields: tuple
    n_cells: int
    modes_width: int = 0
    live: bool = False
    _inode: int = 0

    @property
    def n_frames(self) -> int:
        return int(self.time.shape[0])

    def read(self, name: str, frames=None, cells: slice | None = None) -> np.ndarray:
        """Values of one field for the frame indices ``frames`` (negative ones count from
        the last frame; all if None), of the cells ``cells`` (a slice; all if None)."""
        if name not in self.fields:
            raise TrajectoryError(f"{self.path}: field {name!r} is not stored (has {list(self.fields)})")
        n, key = self.n_frames, f"{CELLS}/{name}/value"
        if frames is None:
            uniq, inv = np.arange(n), None
        else:
            idx = np.asarray(frames, dtype=np.int64)
            if idx.size and (idx.min() < -n or idx.max() >= n):
                raise TrajectoryError(f"{self.path}: frame index out of range for {n} frames")
            uniq, inv = np.unique(idx % max(n, 1), return_inverse=True)
        if not self.live:
            with h5py.File(self.path, "r", locking=False) as f:
                data = _rows(f[key], uniq, cells)
        else:  # pieces, each checked on its own: a long read need not fit between two appends
            rows = max(1, LIVE_PIECE_BYTES // (8 * self.n_cells * max(2, self.modes_width)))
            pieces = [uniq[i:i + rows] for i in range(0, len(uniq), rows)] or [uniq]
            data = _read_live(self.path, n, self._inode, lambda f, p: _rows(f[key], p, cells), pieces)
        return data if inv is None else data[inv]

    @property
    def radii(self) -> np.ndarray | None:
        """Per-cell radii R0,i (``particles/cells/R0``), ``None`` when all cells are equal."""
        with h5py.File(self.path, "r", locking=False) as f:
            ds = f[CELLS].get("R0")
            return None if ds is None else np.asarray(ds[()], dtype=float)

    def unwrapped(self, frames=None) -> np.ndarray:
        """Unwrapped centroids ``position + image * edges``, shape (F, N, 2)."""
        pos = self.read("position", frames)
        img = self.read("image", frames) if "image" in self.fields else np.zeros(pos.shape, np.int64)
        return pos + img * self.box


#: A reader of a running trajectory retries this long while the writer is mid-append ...
LIVE_RETRY_SECONDS = 10.0
#: ... and reads it in pieces of about this many bytes.
LIVE_PIECE_BYTES = 4 << 20


def _rows(ds: h5py.Dataset, uniq: np.ndarray, cells: slice | None = None) -> np.ndarray:
    """Rows ``uniq`` (sorted, distinct) of a dataset, columns ``cells``: one slice when contiguous."""
    cells = slice(None) if cells is None else cells
    if uniq.size == 0:
        return ds[0:0, cells]
    if uniq[-1] - uniq[0] + 1 == uniq.size:
        return ds[int(uniq[0]):int(uniq[-1]) + 1, cells]
    return ds[uniq.tolist(), cells]


def _committed_frames(partial: Path) -> int:
    return RunDirectory(partial.parent, partial.parent.name, -1).committed_frames()


def _try_live(partial: Path, n: int, inode: int, read) -> tuple[bool, Any]:
    """One attempt of ``read(h5py.File)`` on a running run's partial file: ``(True,
    result)`` if no writer touched the file during the read (the same even
    :func:`write_count` before and after: a seqlock), the file is the one opened first (no
    restart from step 0 meanwhile) and its checkpoint still covers ``n`` frames, else
    ``(False, why)``.  Once the run has finished, the repacked ``trajectory.h5`` (the same
    frames) is read instead."""
    final = partial.with_name(schema.TRAJECTORY)
    try:
        if not partial.exists() and final.exists():
            with h5py.File(final, "r", locking=False) as f:
                return True, read(f)
        if partial.stat().st_ino != inode:
            raise TrajectoryError(f"{partial}: the run restarted from step 0 since it was opened; open it again")
        before = write_count(partial)
        if before % 2:
            return False, "a write is in progress (or its writer died during one)"
        with h5py.File(partial, "r", locking=False) as f:
            out = read(f)
        if (write_count(partial) == before and partial.exists() and partial.stat().st_ino == inode
                and _committed_frames(partial) >= n):
            return True, out
        return False, "the file changed while it was read"
    except TrajectoryError:
        raise
    except (OSError, KeyError, ValueError, RuntimeError) as exc:
        return False, f"{type(exc).__name__}: {exc}"


def _read_live(partial: Path, n: int, inode: int, read, pieces=None):
    """:func:`_try_live` until it succeeds (giving up after LIVE_RETRY_SECONDS without
    progress).  With ``pieces`` (index arrays), ``read(f, piece)`` is called per piece and
    the results concatenated; a piece that meets a write is split in two, so that reads
    progress even when appends come quickly."""
    todo = [None] if pieces is None else list(reversed(pieces))
    done, problem = [], "?"
    deadline = _time.monotonic() + LIVE_RETRY_SECONDS
    delay = 0.001
    while todo:
        piece = todo.pop()
        ok, got = _try_live(partial, n, inode, read if piece is None else (lambda f, p=piece: read(f, p)))
        if ok:
            done.append(got)
            deadline, delay = _time.monotonic() + LIVE_RETRY_SECONDS, 0.001
            continue
        problem = got
        if piece is not None and len(piece) > 1:
            todo += [piece[len(piece) // 2:], piece[:len(piece) // 2]]
        else:
            todo.append(piece)
        if _time.monotonic() > deadline:
            raise TrajectoryError(f"{partial}: running trajectory not readable for {LIVE_RETRY_SECONDS:g} s "
                                  f"({problem})")
        _time.sleep(delay)
        delay = min(2 * delay, 0.05)
    return done[0] if pieces is None else np.concatenate(done)


def _metadata(f: h5py.File, path: Path, limit: int | None):
    if CELLS not in f or "position" not in f[CELLS]:
        raise TrajectoryError(f"{path}: no {CELLS}/position time series")
    cells = f[CELLS]
    value = cells["position/value"]
    n = None if limit is None else min(int(limit), value.shape[0], cells["position/time"].shape[0])
    box = np.asarray(cells["box/edges"][()], dtype=float)
    step = np.asarray(cells["position/step"][:n])
    time = np.asarray(cells["position/time"][:n], dtype=float)
    fields = tuple(k for k in cells if k not in STATIC and "value" in cells[k])
    width = cells["shape_a/value"].shape[-1] if "shape_a" in fields else 0
    params = {k: _plain(v) for k, v in f[PARAMETERS].attrs.items()} if PARAMETERS in f else {}
    if limit is None and value.shape[0] != time.shape[0]:
        raise TrajectoryError(f"{path}: {value.shape[0]} position frames but {time.shape[0]} times")
    return params, box, step, time, fields, int(value.shape[1]), width


def open_trajectory(path) -> Trajectory:
    """Open a trajectory's metadata; raise :class:`TrajectoryError` if it is unusable.

    ``path`` is a trajectory file or a run directory.  A run directory without a finished
    ``trajectory.h5`` gives its running ``trajectory.h5.partial``, of which a reader sees
    only the frames the last checkpoint covers (:meth:`RunDirectory.committed_frames`),
    never a frame the writer is still appending; so does a ``.partial`` path.
    """
    path = Path(path)
    if path.is_dir():
        final = path / schema.TRAJECTORY
        path = final if final.exists() else path / schema.TRAJECTORY_PARTIAL
    if not path.exists():
        raise TrajectoryError(f"{path}: no trajectory file")
    if path.name == schema.TRAJECTORY_PARTIAL:
        return _open_live(path)
    try:
        with h5py.File(path, "r", locking=False) as f:
            meta = _metadata(f, path, None)
    except TrajectoryError:
        raise
    except (OSError, KeyError, ValueError) as exc:
        raise TrajectoryError(f"{path}: unreadable trajectory ({exc})") from exc
    return Trajectory(path, *meta)


def _open_live(partial: Path) -> Trajectory:
    final = partial.with_name(schema.TRAJECTORY)
    for _ in range(3):  # the run may finish (partial -> trajectory.h5) while this opens it
        try:
            inode = partial.stat().st_ino
            n = _committed_frames(partial)
        except FileNotFoundError:
            if final.exists():
                return open_trajectory(final)
            continue
        try:
            meta = _read_live(partial, n, inode, lambda f, n=n: _metadata(f, partial, n))
        except TrajectoryError:
            if not partial.exists() and final.exists():
                return open_trajectory(final)
            raise
        return Trajectory(partial, *meta, live=True, _inode=inode)
    raise TrajectoryError(f"{partial}: no trajectory file")
