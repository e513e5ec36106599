"""Write the built-in example of `fcsweep measure`: fcsweep/data/measure_example.npy.

A label stack (uint8, T x Y x X) rendered from a simulated run: 64 cells at eta = 0.01,
v0 = 0.06 (seed 3), 100 time units from the lattice, then 12 frames 1 time unit apart,
rendered at 10 px per R0 (pixel size 0.1 R0) in the field of view 1 R0 inside the periodic
box, each pixel to the cell it lies deepest in (tests/measure_render.py).  About 20 s.

    PYTHONPATH=. python benchmarks/measure_example.py
"""

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from measure_render import render_overlapping  # noqa: E402

from fcsweep.simulation import Simulation  # noqa: E402

#: Pixels per R0 and frames of the example.
RES, FRAMES, STEPS_PER_FRAME = 10, 12, 200


def main() -> None:
    sim = Simulation.from_lattice(64, seed=3, eta=0.01, v0=0.06)
    sim.advance(20000)
    L = sim.state.box
    fov = (1.0, L[0] - 1.0, 1.0, L[1] - 1.0)
    frames = []
    for _ in range(FRAMES):
        s = sim.state
        frames.append(render_overlapping(s.pos, s.theta, s.a, s.b, L, RES, fov).astype(np.uint8))
        sim.advance(STEPS_PER_FRAME)
    out = ROOT / "fcsweep" / "data" / "measure_example.npy"
    np.save(out, np.stack(frames), allow_pickle=False)
    print(out, np.stack(frames).shape)


if __name__ == "__main__":
    main()
