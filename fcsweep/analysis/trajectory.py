"""Read one H5MD trajectory of the contract layout (the only file reader of analysis).

``/particles/cells/{position,image,theta,shape_a,shape_b}/{step,time,value}``,
``/particles/cells/box/edges`` and the attributes of ``/parameters``.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np

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
        Of all frames in the file.
    fields : tuple of str
        Stored per-cell time series.
    """

    path: Path
    params: dict
    box: np.ndarray
    step: np.ndarray
    time: np.ndarray
    fields: tuple
    n_cells: int
    modes_width: int = 0

    @property
    def n_frames(self) -> int:
        return int(self.time.shape[0])

    def read(self, name: str, frames=None) -> np.ndarray:
        """Values of one field for the frame indices ``frames`` (sorted; all if None)."""
        if name not in self.fields:
            raise TrajectoryError(f"{self.path}: field {name!r} is not stored (has {list(self.fields)})")
        with h5py.File(self.path, "r", locking=False) as f:
            ds = f[f"{CELLS}/{name}/value"]
            if frames is None:
                return ds[()]
            idx = np.asarray(frames, dtype=np.int64) % ds.shape[0]
            uniq, inv = np.unique(idx, return_inverse=True)
            if uniq.size and uniq[-1] - uniq[0] + 1 == uniq.size:  # contiguous: one slice
                data = ds[int(uniq[0]):int(uniq[-1]) + 1]
            else:
                data = ds[uniq.tolist()]
            return data[inv]

    def unwrapped(self, frames=None) -> np.ndarray:
        """Unwrapped centroids ``position + image * edges``, shape (F, N, 2)."""
        pos = self.read("position", frames)
        img = self.read("image", frames) if "image" in self.fields else np.zeros(pos.shape, np.int64)
        return pos + img * self.box


def open_trajectory(path) -> Trajectory:
    """Open a trajectory's metadata; raise :class:`TrajectoryError` if it is unusable."""
    path = Path(path)
    if not path.exists():
        raise TrajectoryError(f"{path}: no trajectory file")
    try:
        with h5py.File(path, "r", locking=False) as f:
            if CELLS not in f or "position" not in f[CELLS]:
                raise TrajectoryError(f"{path}: no {CELLS}/position time series")
            cells = f[CELLS]
            box = np.asarray(cells["box/edges"][()], dtype=float)
            step = np.asarray(cells["position/step"][()])
            time = np.asarray(cells["position/time"][()], dtype=float)
            value = cells["position/value"]
            fields = tuple(k for k in cells if k != "box" and "value" in cells[k])
            width = cells["shape_a/value"].shape[-1] if "shape_a" in fields else 0
            params = {k: _plain(v) for k, v in f[PARAMETERS].attrs.items()} if PARAMETERS in f else {}
            n_cells = int(value.shape[1])
            if value.shape[0] != time.shape[0]:
                raise TrajectoryError(f"{path}: {value.shape[0]} position frames but {time.shape[0]} times")
    except TrajectoryError:
        raise
    except (OSError, KeyError, ValueError) as exc:
        raise TrajectoryError(f"{path}: unreadable trajectory ({exc})") from exc
    return Trajectory(path, params, box, step, time, fields, n_cells, width)


def config_json(params: dict) -> dict:
    """The sweep config recorded in ``/parameters`` (``config_json``), or {}."""
    try:
        return json.loads(params.get("config_json", "{}"))
    except (TypeError, ValueError):
        return {}
