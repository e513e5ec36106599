"""Analysis cost per frame against N: today's per-frame observables and the FFT correlations.

Usage:
    python benchmarks/scaling.py                       # N = 1024 ... 99 856 (a few CPU-minutes)
    python benchmarks/scaling.py --N 1024 4096 --out benchmarks/results/scaling_analysis.txt
    python benchmarks/scaling.py --end-to-end          # the CLI end to end, N = 1024 4096 16384
    python benchmarks/scaling.py --end-to-end --large  # ... and N = 99 856
    python benchmarks/scaling.py --threads             # step cell-steps/s at 1 and 2 threads, N = 1024 ... 10^6

``--end-to-end`` simulates, analyses (FFT correlations) and aggregates one short run per N
with the real CLI and writes ``benchmarks/results/scaling_end_to_end.txt``
(:mod:`end_to_end`: cell-steps/s, analysis CPU per frame, peak RSS, bytes per frame and
per checkpoint, aggregate time, and the analysis/simulation ratio of a 501-frame run),
then the thread table below for the same N.
``--threads`` times the step alone at 1 and 2 numba threads (:mod:`thread_scaling`:
blocks alternating between the thread counts on one state, wall clock) for N = 1024,
10^4, 99 856 and 10^6 (``--N`` to choose) and writes
``benchmarks/results/scaling_threads.txt``.

One synthetic frame per N (``benchmarks/snapshots.dense_snapshot``: a hexagonal lattice at
area fraction 0.9 with Gaussian jitter 0.1 R0 and random admissible shapes, lengths in R0,
as the pipeline passes them; no simulation), N = n^2 with n even.  Each row is the CPU
seconds (``time.process_time``, freud on one thread) of one call, as the pipeline makes it
(pipeline settings ``g6_dr = 0.1``, ``gr_dx = 0.2``):

- ``Voronoi``: ``voronoi.voronoi_neighbors``; ``psi6``: ``order.psi6`` on its neighbours;
  ``q``: ``shapes.shape_indices`` of every cell;
- pair counts (O(N^2)): ``G6`` = ``order.g6`` (freud's CorrelationFunction);
  ``pairs`` = ``order.pair_vectors`` out to half the box (the query G_r and C_G1 share;
  ~100 bytes per pair: 1.1 GB at N = 4096, so it is run only up to ``--pair-max``);
  ``G_r`` = ``order.gr_cut`` on those vectors; ``C_G1`` = ``order.first_shell_vectors``
  plus ``order.shell_correlation``;
- FFT (``fcsweep.analysis.correlation_fft``, default grid ``h = dr / sqrt 2``): each
  curve alone and the three from one grid (``correlations``, how a pipeline would call it).

Entries beyond ``--pair-max`` (``--g6-max`` for G6) are extrapolated as ``N^2`` from the
largest measured N and marked ``~``.
"""

from __future__ import annotations

import argparse
import pathlib
import sys
import time

import freud
import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from snapshots import dense_snapshot  # noqa: E402

from fcsweep.analysis import correlation_fft, order, shapes, voronoi  # noqa: E402
from fcsweep.analysis.cage import neighbour_spacing  # noqa: E402

DR, DX = 0.1, 0.2
ROWS = ("Voronoi", "psi6", "q", "G6 pairs", "pair query", "G_r pairs", "C_G1 pairs", "pair total",
        "G6 FFT", "G_r FFT", "C_G1 FFT", "all FFT")


def _cpu(f):
    t = time.process_time()
    out = f()
    return time.process_time() - t, out


def measure(N: int, *, pair_max: int, g6_max: int, seed: int = 1) -> dict:
    """CPU seconds per observable for one frame of ``N`` cells (NaN where not run)."""
    s = dense_snapshot(N, 0.9, seed=seed, jitter=0.1)
    pos, box = s["pos"], (float(s["box"][0]), float(s["box"][1]))
    out = {}
    out["Voronoi"], vn = _cpu(lambda: voronoi.voronoi_neighbors(pos, box))
    out["psi6"], ps = _cpu(lambda: order.psi6(pos, box, vn.nlist))
    out["q"], _ = _cpu(lambda: shapes.shape_indices(s["a"], s["b"], 1.0))
    _, ang = order.global_psi6(ps)
    t_G, G1 = _cpu(lambda: order.first_shell_vectors(pos, box, ang, neighbour_spacing(N, box)))
    nan = float("nan")
    out["G6 pairs"] = _cpu(lambda: order.g6(pos, box, ps, dr=DR))[0] if N <= g6_max else nan
    if N <= pair_max:
        out["pair query"], v = _cpu(lambda: order.pair_vectors(pos, box, order.max_range(box)))
        out["G_r pairs"] = _cpu(lambda: order.gr_cut(pos, box, ang, dx=DX, vectors=v))[0]
        out["C_G1 pairs"] = t_G + _cpu(lambda: order.shell_correlation(v, G1, dr=DR, r_max=order.max_range(box)))[0]
        del v
    else:
        out["pair query"] = out["G_r pairs"] = out["C_G1 pairs"] = nan
    out["G6 FFT"] = _cpu(lambda: correlation_fft.g6(pos, box, ps, dr=DR))[0]
    out["G_r FFT"] = _cpu(lambda: correlation_fft.gr_cut(pos, box, ang, dx=DX))[0]
    out["C_G1 FFT"] = t_G + _cpu(lambda: correlation_fft.shell_correlation(pos, box, G1, dr=DR))[0]
    out["all FFT"], c = _cpu(lambda: correlation_fft.correlations(pos, box, psi=ps, G=G1, orientation=ang,
                                                                  dr=DR, dx=DX))
    out["all FFT"] += t_G
    out["grid"] = c.grid.size
    return out


def table(sizes, results) -> str:
    """The rows of :data:`ROWS` against N, extrapolating the pair rows as N^2 where not run."""
    done = {}
    for row in ROWS:
        if row == "pair total":
            continue
        known = [(n, r[row]) for n, r in zip(sizes, results) if np.isfinite(r[row])]
        done[row] = []
        for n, r in zip(sizes, results):
            if np.isfinite(r[row]):
                done[row].append(f"{r[row]:.3g}")
            elif known:
                n0, t0 = known[-1]
                done[row].append(f"~{t0 * (n / n0) ** 2:.3g}")
            else:
                done[row].append("-")
    tot = []
    for i in range(len(sizes)):
        parts = [done[k][i] for k in ("G6 pairs", "pair query", "G_r pairs", "C_G1 pairs")]
        approx = any(p.startswith("~") for p in parts)
        val = sum(float(p.lstrip("~")) for p in parts if p != "-")
        tot.append(("~" if approx else "") + f"{val:.3g}")
    done["pair total"] = tot
    width = 12
    lines = ["CPU seconds per frame (one core); ~ = extrapolated as N^2 from the largest N run",
             "observable".ljust(14) + "".join(f"N={n}".rjust(width) for n in sizes)]
    for row in ROWS:
        lines.append(row.ljust(14) + "".join(v.rjust(width) for v in done[row]))
    lines.append("grid cells M".ljust(14) + "".join(f"{r['grid']:.3g}".rjust(width) for r in results))
    lines.append("M / N".ljust(14) + "".join(f"{r['grid'] / n:.0f}".rjust(width) for n, r in zip(sizes, results)))
    ratio = [float(t.lstrip("~")) / r["all FFT"] for t, r in zip(tot, results)]
    lines.append("pairs / FFT".ljust(14) + "".join(f"{x:.3g}".rjust(width) for x in ratio))
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--N", type=int, nargs="+", default=[1024, 4096, 16384, 65536, 99856])
    ap.add_argument("--pair-max", type=int, default=4096, help="largest N for the pair query (memory)")
    ap.add_argument("--g6-max", type=int, default=16384, help="largest N for the pair-count G6")
    ap.add_argument("--out", type=pathlib.Path, help="also write the table here")
    ap.add_argument("--end-to-end", action="store_true", help="simulate, analyze, aggregate with the CLI")
    ap.add_argument("--large", action="store_true", help="with --end-to-end: add N = 99 856")
    ap.add_argument("--threads", action="store_true", help="the step at 1 and 2 numba threads against N")
    ap.add_argument("--steps", type=int, default=400, help="with --end-to-end: steps per run")
    ap.add_argument("--every", type=int, default=100, help="with --end-to-end: steps between frames")
    ap.add_argument("--msd-max", type=int, default=16384,
                    help="with --end-to-end: largest N of the synthetic 401-frame MSD+D_eff timing")
    ap.add_argument("--keep", type=pathlib.Path, help="with --end-to-end: keep the runs under this directory")
    args = ap.parse_args(argv)
    given_N = "--N" in (argv if argv is not None else sys.argv)
    results_dir = pathlib.Path(__file__).resolve().parent / "results"
    if args.threads:
        import thread_scaling

        sizes = args.N if given_N else [1024, 10000, 99856, 1000000]
        thread_scaling.main(sizes, out=args.out or results_dir / "scaling_threads.txt")
        return
    if args.end_to_end:
        import end_to_end
        import thread_scaling

        sizes = args.N if given_N else [1024, 4096, 16384]
        sizes = sizes + ([99856] if args.large and 99856 not in sizes else [])
        out = args.out or results_dir / "scaling_end_to_end.txt"
        end_to_end.main(sizes, steps=args.steps, every=args.every, msd_max=args.msd_max, out=out, keep=args.keep)
        thread_scaling.main(sizes, out=out.with_name(out.stem + "_threads.txt"))
        return
    freud.parallel.set_num_threads(1)
    results = []
    for N in args.N:
        results.append(measure(N, pair_max=args.pair_max, g6_max=args.g6_max))
        print(f"N = {N}: " + ", ".join(f"{k} {v:.3g}" for k, v in results[-1].items()), flush=True)
    text = table(args.N, results)
    print(text)
    if args.out:
        args.out.write_text(text + "\n")


if __name__ == "__main__":
    main()
