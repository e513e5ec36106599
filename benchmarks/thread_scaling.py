"""Step throughput at 1 and 2 numba threads against N, interleaved on one state.

Called by ``python benchmarks/scaling.py --threads`` (and by ``--end-to-end``).  For each
N (= n^2, n even) one :class:`fcsweep.simulation.Simulation` of the end-to-end model
(v0 = 0.03, Dr = 0.01, eta = 0.1, density 0.95, M = 6, K = 40, binary rule) is built on
the hexagonal lattice and integrated ``warm`` steps off it; then blocks of about
``cell_steps`` cell-steps are timed (wall clock) alternately at 1 and 2 threads on the
same, evolving state, ``repeats`` blocks each.  Alternating blocks on one state is what
makes the ratio meaningful on a shared machine: a load that comes and goes hits both
thread counts alike.  Reported: the median cell-steps per second of each thread count,
the ratio 2 / 1, and the spread ``(max - min) / median`` of each count's blocks.

At N = 10^6 the state is a few steps off the lattice (the warm-up alone would take
minutes), so its contacts are those of a near-lattice, not of a steady state.
"""

from __future__ import annotations

import time

import numba
import numpy as np

MODEL = dict(v0=0.03, Dr=0.01, eta=0.1, density=0.95, modes=6, contour_points=40, quadrature="binary")


def interleaved(N: int, *, cell_steps: float = 4e6, warm_cell_steps: float = 2e7, repeats: int = 3,
                threads=(1, 2), seed: int = 3) -> dict:
    """Median wall-clock cell-steps/s of ``Simulation.advance`` at each thread count.

    Parameters
    ----------
    N : int
        Number of cells (n^2, n even).
    cell_steps : float
        Work of one timed block; its steps are ``max(2, round(cell_steps / N))``.
    warm_cell_steps : float
        Work before timing (at least 2 steps), at the largest thread count.
    repeats : int
        Timed blocks per thread count, alternating between the counts.
    threads : tuple of int
        Thread counts to compare (each at most ``numba.config.NUMBA_NUM_THREADS``).
    seed : int
        Seed of the run.

    Returns
    -------
    dict
        ``N``, ``steps`` (per block), ``rate`` and ``spread`` keyed by thread count.
    """
    from fcsweep.simulation import Simulation

    previous = numba.get_num_threads()
    steps = max(2, int(round(cell_steps / N)))
    times = {t: [] for t in threads}
    try:
        sim = Simulation.from_lattice(N, seed=seed, **MODEL)
        numba.set_num_threads(max(threads))
        sim.advance(max(2, int(round(warm_cell_steps / N))))
        for _ in range(repeats):
            for t in threads:
                numba.set_num_threads(t)
                t0 = time.perf_counter()
                sim.advance(steps)
                times[t].append(time.perf_counter() - t0)
    finally:
        numba.set_num_threads(previous)
    rate = {t: N * steps / float(np.median(v)) for t, v in times.items()}
    spread = {t: (max(v) - min(v)) / float(np.median(v)) for t, v in times.items()}
    return {"N": N, "steps": steps, "rate": rate, "spread": spread}


def table(results, threads=(1, 2)) -> str:
    """One row per N: cell-steps/s at each thread count, their ratio and the blocks' spread."""
    head = f"{'N':>8} {'steps/block':>11} " + " ".join(f"{f'{t} thr cs/s':>12}" for t in threads)
    head += f" {'ratio':>6} " + " ".join(f"{f'spread {t}':>9}" for t in threads)
    lines = [head]
    for r in results:
        row = f"{r['N']:>8d} {r['steps']:>11d} " + " ".join(f"{r['rate'][t]:>12.3g}" for t in threads)
        row += f" {r['rate'][threads[-1]] / r['rate'][threads[0]]:>6.2f} "
        row += " ".join(f"{r['spread'][t]:>9.2f}" for t in threads)
        lines.append(row)
    lines.append(f"wall-clock cell-steps per second of the step (median of the blocks, alternating thread counts on "
                 f"one state); ratio: {threads[-1]} threads / {threads[0]}")
    return "\n".join(lines)


def main(sizes, *, out=None, repeats: int = 3) -> str:
    """Measure every N of ``sizes``, print the table and write it to ``out``."""
    threads = (1, 2) if numba.config.NUMBA_NUM_THREADS >= 2 else (1,)
    results = []
    for N in sizes:
        results.append(interleaved(N, repeats=repeats, threads=threads))
        print(results[-1], flush=True)
    text = table(results, threads)
    print(text)
    if out:
        from pathlib import Path

        Path(out).write_text(text + "\n")
    return text
