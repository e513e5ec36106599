"""What the dry run's probe state says a step costs, against the step of a run that flows.

For each scene and N, in one process at one numba thread (process CPU time, median of 5
blocks of 1e5 cell-steps):

- ``probe``: :func:`fcsweep.sweep.cost.measure_point` (a disordered start, see
  :mod:`fcsweep.sweep.cost`);
- ``lattice probe``: the former probe, the step timed 4e5 cell-steps off the lattice;
- ``lattice run`` / ``disordered run``: the step after ``--steps`` steps of a run from the
  lattice / from the disordered start (the cost a long run pays).

Usage:
    python benchmarks/cost_probe.py                   # N = 1024 and 10^4 (about 10 min)
    python benchmarks/cost_probe.py --n 1024 --steps 4000
"""

from __future__ import annotations

import argparse
import statistics
import time

SCENES = {
    "area fraction 0.8, eta 0.03, v0 0.06, binary (Fig. 1c)":
        dict(eta=0.03, v0=0.06, Dr=0.01, density=0.8, dt=0.005, quadrature="binary"),
    "area fraction 0.95, eta 0.1, v0 0.01, binary (solid)":
        dict(eta=0.1, v0=0.01, Dr=0.01, density=0.95, dt=0.005, quadrature="binary"),
    "area fraction 0.95, eta 0.01, v0 0.1, arc (fluid)":
        dict(eta=0.01, v0=0.1, Dr=0.01, density=0.95, dt=0.005, quadrature="arc"),
}


def timed(sim, N, block=1e5, repeats=5) -> float:
    """Median microseconds per cell-step over ``repeats`` blocks (process CPU time)."""
    steps = max(10, int(block // N))
    blocks = []
    for _ in range(repeats):
        t0 = time.process_time()
        sim.advance(steps)
        blocks.append((time.process_time() - t0) / (N * steps))
    return statistics.median(blocks) * 1e6


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, nargs="+", default=[1024, 10000])
    ap.add_argument("--steps", type=int, default=10000, help="steps of the runs before their step is timed")
    ap.add_argument("--arc-max-n", type=int, default=1024, help="largest N of the arc scene (4x the binary cost)")
    args = ap.parse_args()

    import numba

    from fcsweep.simulation import Simulation
    from fcsweep.sweep.cost import measure_point

    numba.set_num_threads(1)
    print(f"# python benchmarks/cost_probe.py --n {' '.join(map(str, args.n))} --steps {args.steps}   "
          f"({time.strftime('%Y-%m-%d')}, one thread, us per cell-step)")
    print(f"{'N':>6}  {'scene':55s} {'probe':>6} {'lattice probe':>13} {'lattice run':>11} {'disordered run':>14}")
    for N in args.n:
        for name, model in SCENES.items():
            if "arc" in name and N > args.arc_max_n:
                continue
            params = dict(model, N=N, seed=7)
            probe = measure_point(params)[0] * 1e6
            lat = Simulation.from_lattice(**params)
            lat.advance(max(10, int(4e5 // N)))
            lattice_probe = timed(lat, N)
            lat.advance(args.steps)
            dis = Simulation.from_disordered(**params)
            dis.advance(args.steps)
            print(f"{N:>6}  {name:55s} {probe:6.3f} {lattice_probe:13.3f} {timed(lat, N):11.3f} "
                  f"{timed(dis, N):14.3f}", flush=True)


if __name__ == "__main__":
    main()
