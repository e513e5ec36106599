"""Throughput of the step: cell-steps per second after leaving the lattice.

Usage:
    python benchmarks/throughput.py                   # the full table (a few minutes)
    python benchmarks/throughput.py --N 1024 --threads 1 --quadrature binary

Paper settings: rho = 0.95, K = 40, M = 6, dt = 5e-3, v0 = 0.06, eta = 0.03.  Each row
first integrates ``--warm`` steps off the lattice (so contacts and shapes are those of
a steady state), then reports the best of three timed blocks.  Ratios printed in the
same run (threads vs 1 thread, N = 10 000 vs 1024, quadrature vs binary, discs vs
contours) are the meaningful numbers on a shared, noisy machine.
"""

from __future__ import annotations

import argparse

import numba

from fcsweep.simulation import Simulation
from fcsweep.sweep.bench import measure_throughput


def measure(N, quadrature, threads, steps, warm, modes=6, seed=1):
    """Best-of-three cell-steps per second of ``Simulation.advance`` (wall clock)."""
    params = dict(N=N, eta=0.03, v0=0.06, Dr=0.01, seed=seed, quadrature=quadrature, modes=modes)
    return measure_throughput(params, steps=steps, warm=warm, threads=threads)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--N", type=int, nargs="+", default=[1024, 10000])
    ap.add_argument("--steps", type=int, default=200, help="timed steps per block at N = 1024 (scaled by 1024/N)")
    ap.add_argument("--warm", type=int, default=2000, help="steps off the lattice before timing (N <= 4096; 500 above)")
    ap.add_argument("--quadrature", nargs="+", default=["binary", "linear", "arc", "disc"],
                    help="contour rules, and 'disc' for the rigid-disc path (modes = 0)")
    ap.add_argument("--threads", type=int, nargs="+", default=sorted({1, numba.config.NUMBA_NUM_THREADS}))
    args = ap.parse_args(argv)
    Simulation.from_lattice(16, eta=0.03, v0=0.06, seed=0).advance(2)  # compile outside the timing
    print(f"{'N':>6} {'rule':>7} {'threads':>7} {'cell-steps/s':>13} {'us/cell-step':>12}  ratios")
    rates = {}
    for N in args.N:
        steps = max(args.steps * 1024 // N, 20)
        warm = args.warm if N <= 4096 else 500
        for q in args.quadrature:
            for t in args.threads:
                modes = 0 if q == "disc" else 6
                r = measure(N, "binary" if q == "disc" else q, t, steps, warm, modes)
                rates[(N, q, t)] = r
                notes = []
                if t != args.threads[0]:
                    notes.append(f"x{r / rates[(N, q, args.threads[0])]:.2f} vs {args.threads[0]} thread")
                if q != "binary" and (N, "binary", t) in rates:
                    notes.append(f"cost x{rates[(N, 'binary', t)] / r:.2f} of binary")
                if N != args.N[0] and (args.N[0], q, t) in rates:
                    notes.append(f"per-cell rate x{r / rates[(args.N[0], q, t)]:.2f} of N={args.N[0]}")
                print(f"{N:>6} {q:>7} {t:>7} {r:>13.3e} {1e6 / r:>12.3f}  {'; '.join(notes)}", flush=True)


if __name__ == "__main__":
    main()
