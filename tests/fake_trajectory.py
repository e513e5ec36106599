"""A stand-in for :class:`fcsweep.io.trajectory.Trajectory` with the parts snapshots and movie
frames read: 16 cells on a lattice drifting by ``step`` per frame, no shapes."""

import numpy as np

from fcsweep.model.lattice import hexagonal_lattice


class FakeTrajectory:
    def __init__(self, n_frames=3, step=0.01):
        self.pos, self.box = hexagonal_lattice(16)
        self.params = {"run_id": "abc", "eta": 0.05, "v0": 0.03, "R0": 1.0}
        self.time = np.arange(n_frames) * 2.5
        self.n_frames = n_frames
        self.fields = {"position", "theta"}
        self.step = step

    def read(self, name, frames):
        if name == "position":
            return np.stack([self.pos + self.step * k for k in frames])
        return np.zeros((len(frames), len(self.pos)))
