"""Bias and per-cell error of the shape index of `fcsweep measure` on shapes with exact answers
(docs/measure.md, "How q is measured"): discs, regular hexagons, squares, ellipses of aspect
1-7, exact Voronoi monolayers and model cells, Gauss-digitised (a pixel is in a cell when its
centre is) at random sub-pixel offsets and orientations.

    PYTHONPATH=. python benchmarks/measure_shapes.py [--n 16] > benchmarks/results/measure_shapes.txt
"""

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from measure_render import (ellipse_frame, exact_q, jittered_cells, polygon_frame, regular_polygon,  # noqa: E402
                            render, voronoi_monolayer)

from fcsweep.measure.cells import ESTIMATORS, measure_cells  # noqa: E402
from fcsweep.model.shape import Q_STAR  # noqa: E402


def single(make, n, rng):
    """(q, q_exact, estimator, q_fit, q_err) of n single shapes."""
    rows = []
    for _ in range(n):
        frame, qx = make(rng)
        c = measure_cells(frame)
        rows.append((c["q"][0], qx, c["q_estimator"][0], c["q_fit"][0], c["q_err"][0]))
    return np.array(rows)


def line(name, r):
    q, qx, est, qfit, qerr = r.T
    rel = q / qx - 1
    used = ", ".join(f"{ESTIMATORS[int(k)]} {np.mean(est == k):.2f}" for k in np.unique(est))
    print(f"{name:34s} q {100 * rel.mean():+6.2f} % (rms {100 * np.sqrt(np.mean(rel ** 2)):5.2f} %, worst "
          f"{100 * rel[np.argmax(abs(rel))]:+6.2f} %)  fit {100 * np.mean(qfit / qx - 1):+6.2f} %  "
          f"q_err/q {100 * np.mean(qerr / q):4.2f} %  [{used}]", flush=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=16, help="shapes per row")
    n = ap.parse_args().n
    rng = np.random.default_rng(47)
    for R in (5, 10, 20):
        line(f"disc R = {R} px", single(lambda g, R=R: ellipse_frame(R, R, 0.0, g), n, rng))
    for R in (10, 15, 20):
        line(f"regular hexagon R = {R} px", single(
            lambda g, R=R: polygon_frame(regular_polygon(6, R, g.uniform(0, np.pi)), g), n, rng))
    for side in (19, 40):
        line(f"square side {side} px", single(
            lambda g, side=side: polygon_frame(regular_polygon(4, side / np.sqrt(2), g.uniform(0, np.pi)), g), n,
            rng))
    for asp in (1, 2, 4, 7):
        for b in (5, 10):
            line(f"ellipse aspect {asp}, b = {b} px", single(
                lambda g, asp=asp, b=b: ellipse_frame(asp * b, b, g.uniform(0, np.pi), g), n, rng))
    for cell, size in ((20, 400), (40, 640)):
        frame, qx = voronoi_monolayer(size, cell, rng)
        c = measure_cells(frame)
        ok = np.isfinite(qx[c["label"]]) & (c["shape_flag"] == 0)
        q, qe = c["q"][ok], qx[c["label"][ok]]
        rel = q / qe - 1
        print(f"Voronoi {cell} px per cell ({ok.sum()} cells): <q> {q.mean():.4f} exact {qe.mean():.4f} "
              f"({100 * (q.mean() / qe.mean() - 1):+.2f} %), per cell rms {100 * np.sqrt(np.mean(rel ** 2)):.2f} %; "
              f"fraction above {Q_STAR}: {np.mean(q > Q_STAR):.3f} exact {np.mean(qe > Q_STAR):.3f}; fit <q> "
              f"{100 * (c['q_fit'][ok].mean() / qe.mean() - 1):+.2f} %; estimators "
              f"{np.bincount(c['q_estimator'][ok], minlength=4)[1:].tolist()}", flush=True)
    for res in (5, 10, 20):
        pos, theta, a, b = jittered_cells(20, np.random.default_rng(1), spacing=3.0, sweeps=20)
        fov = (1.0, pos[:, 0].max() - 1.0, 0.5, pos[:, 1].max() - 0.5)
        c = measure_cells(render(pos, theta, a, b, res, fov))
        ok = c["shape_flag"] == 0
        qe = exact_q(a, b)[c["label"][ok] - 1]
        rel = c["q"][ok] / qe - 1
        print(f"model cells {res} px per R0 ({ok.sum()} cells): <q> {100 * (c['q'][ok].mean() / qe.mean() - 1):+.3f} %"
              f", per cell rms {100 * np.sqrt(np.mean(rel ** 2)):.2f} %, fit <q> "
              f"{100 * (c['q_fit'][ok].mean() / qe.mean() - 1):+.3f} %; estimators "
              f"{np.bincount(c['q_estimator'][ok], minlength=4)[1:].tolist()}", flush=True)


if __name__ == "__main__":
    main()
