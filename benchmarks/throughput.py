"""Throughput of the step kernel: cell-steps per second after leaving the lattice.

Usage: python benchmarks/throughput.py [--N 1024 10000] [--steps 200] [--warm 2000]
       [--quadrature binary arc] [--threads 1 2]

Paper settings: rho = 0.95, K = 40, M = 6, dt = 5e-3, v0 = 0.06, eta = 0.03.  Each row
warms the state up off the lattice first (``--warm`` steps), then times ``--steps``.
Threads compare within one run, so the ratios are meaningful on a noisy machine.
"""

from __future__ import annotations

import argparse
import time

import numba

from fcsweep.simulation import Simulation


def measure(N, quadrature, threads, steps, warm, modes=6, seed=1):
    numba.set_num_threads(threads)
    sim = Simulation.from_lattice(N, eta=0.03, v0=0.06, Dr=0.01, seed=seed, quadrature=quadrature, modes=modes)
    sim.advance(warm)
    best = float("inf")
    for _ in range(3):
        t0 = time.perf_counter()
        sim.advance(steps)
        best = min(best, time.perf_counter() - t0)
    return N * steps / best, sim


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--N", type=int, nargs="+", default=[1024, 10000])
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--warm", type=int, default=2000)
    ap.add_argument("--quadrature", nargs="+", default=["binary", "linear", "arc"])
    ap.add_argument("--threads", type=int, nargs="+", default=[1, numba.config.NUMBA_NUM_THREADS])
    ap.add_argument("--modes", type=int, default=6)
    args = ap.parse_args(argv)
    # compile once
    Simulation.from_lattice(16, eta=0.03, v0=0.06, seed=0).advance(2)
    print(f"{'N':>6} {'quadrature':>10} {'threads':>7} {'cell-steps/s':>14} {'us/cell-step':>13}")
    base = {}
    for N in args.N:
        warm = args.warm if N <= 4096 else max(args.warm // 4, 200)
        for q in args.quadrature:
            for t in args.threads:
                rate, _ = measure(N, q, t, args.steps if N <= 4096 else max(args.steps // 4, 20), warm, args.modes)
                base.setdefault((N, q), rate)
                print(f"{N:>6} {q:>10} {t:>7} {rate:>14.3e} {1e6 / rate:>13.3f}"
                      f"   x{rate / base[(N, q)]:.2f} vs 1 thread")


if __name__ == "__main__":
    main()
