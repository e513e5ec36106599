"""The wall term's own cost: one confined state's rates with the wall term and without it.

    NUMBA_NUM_THREADS=1 python benchmarks/wall_cost.py [--N 1024] [--blocks 9] [--calls 100]

For a well and a channel (area fraction 0.95, eta = 0.05, v0 = 0.03, disordered start then
200 steps) and each rule (binary, arc), the same state's deterministic rates are computed
``--calls`` times with the wall term and as often without it (its code zeroed in the
parameter vector), in interleaved blocks timed by CPU time; the table gives cell-steps/s of
each (median over the blocks) and their ratio.  Stepping a confined run without its wall
would change the packing (cells escape and decompress), so the state is held fixed here.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from fcsweep.kernels.records import P_WALL
from fcsweep.kernels.step import compute_rates
from fcsweep.simulation import Simulation


def rates_rate(sim: Simulation, prm: np.ndarray, calls: int) -> float:
    """Cell-rate evaluations per CPU second of ``calls`` calls on the simulation's state."""
    s, ws = sim.state, sim._ws
    t0 = time.process_time()
    for _ in range(calls):
        compute_rates(s.pos, s.theta, s.a, s.b, prm, True, sim._quad, ws.tables, ws.scratch, ws.cl, ws.nl, ws.out)
    return sim.params.N * calls / (time.process_time() - t0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--N", type=int, default=1024)
    ap.add_argument("--blocks", type=int, default=9)
    ap.add_argument("--calls", type=int, default=100)
    args = ap.parse_args()
    print(f"N = {args.N}, {args.calls} rate evaluations x {args.blocks} interleaved blocks, CPU time")
    print(f"{'case':28s} {'off cell-st/s':>14s} {'on cell-st/s':>14s} {'on / off':>9s}  wall cells")
    for boundary in ("well", "channel"):
        for quad in ("binary", "arc"):
            sim = Simulation.create(args.N, seed=3, eta=0.05, v0=0.03, quadrature=quad, boundary=boundary,
                                    initial="disordered")
            sim.advance(200)
            on = sim._prm
            off = on.copy()
            off[P_WALL] = 0.0
            rates_rate(sim, on, 5)
            rates_rate(sim, off, 5)  # warm
            r_on, r_off = [], []
            for _ in range(args.blocks):
                r_off.append(rates_rate(sim, off, args.calls))
                r_on.append(rates_rate(sim, on, args.calls))
            geo = sim._ws.scratch.geo
            near = int(np.sum(-sim.confinement.inside_distance(sim.state.pos) + geo[:, 1] > 0))
            a, b = float(np.median(r_off)), float(np.median(r_on))
            print(f"{boundary + ', ' + quad:28s} {a:14.4g} {b:14.4g} {b / a:9.4f}  {near} of {args.N}", flush=True)


if __name__ == "__main__":
    main()
