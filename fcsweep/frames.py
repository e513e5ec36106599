"""Frames of one run held in memory: what :meth:`fcsweep.simulation.Simulation.run` records
and :func:`fcsweep.observables` analyses.

A :class:`Frames` holds, for T frames of N cells, the same per-cell fields a sweep's
``trajectory.h5`` stores (float64 positions wrapped into the box with their box crossings,
polarity angles, shape modes), the frame steps and times, the box, the run's parameters
(:meth:`fcsweep.simulation.SimParams.to_dict`, seed included) and the per-cell radii when
sizes differ.  The values are those the sweep runner writes for the same run: frames
recorded in memory and frames read from the file give the same observables, bit for bit.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["Frames"]


@dataclass
class Frames:
    """T recorded frames of one run.

    Attributes
    ----------
    params : dict
        The run's parameters (``N``, ``eta``, ``v0``, ``dt``, ``seed``, ...).
    box : ndarray, shape (2,)
        Periodic box (Lx, Ly) (in a well or channel: the host box around it).
    step, time : ndarray, shape (T,)
        Step and time (``step * dt``) of each frame.
    position : ndarray, shape (T, N, 2)
        Centres wrapped into the box.
    image : ndarray, shape (T, N, 2)
        Box crossings: the unwrapped centres are ``position + image * box``.
    theta : ndarray, shape (T, N)
        Polarity angles (not wrapped).
    shape_a, shape_b : ndarray, shape (T, N, M - 1)
        Shape modes n = 2..M (empty for rigid discs).
    radii : ndarray, shape (N,), or None
        Per-cell radii R0,i (None: every cell has R0).
    """

    params: dict
    box: np.ndarray
    step: np.ndarray
    time: np.ndarray
    position: np.ndarray
    image: np.ndarray
    theta: np.ndarray
    shape_a: np.ndarray
    shape_b: np.ndarray
    radii: np.ndarray | None = None
    meta: dict[str, Any] = field(default_factory=dict)

    def __len__(self) -> int:
        return int(self.time.shape[0])

    @property
    def n_cells(self) -> int:
        """Number of cells N."""
        return int(self.position.shape[1])

    def unwrapped(self) -> np.ndarray:
        """Unwrapped centres ``position + image * box``, shape (T, N, 2)."""
        return self.position + self.image * self.box

    def __repr__(self) -> str:
        t = f"t = {self.time[0]:g} .. {self.time[-1]:g}" if len(self) else "empty"
        return f"Frames({len(self)} frames of {self.n_cells} cells, {t})"

    @classmethod
    def from_snapshots(cls, snapshots: list[dict], params: dict, box, radii=None) -> "Frames":
        """Stack per-frame dicts (``step``, ``time``, ``position``, ``image``, ``theta``,
        ``shape_a``, ``shape_b``) into one :class:`Frames`."""
        def stack(name, dtype):
            return np.stack([np.asarray(s[name], dtype=dtype) for s in snapshots])

        return cls(params=dict(params), box=np.array(box, dtype=float),
                   step=np.array([s["step"] for s in snapshots], dtype=np.int64),
                   time=np.array([s["time"] for s in snapshots], dtype=float),
                   position=stack("position", float), image=stack("image", np.int64), theta=stack("theta", float),
                   shape_a=stack("shape_a", float), shape_b=stack("shape_b", float),
                   radii=None if radii is None else np.array(radii, dtype=float))
