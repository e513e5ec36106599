"""Figure of docs/model.md's confinement paragraph: cells in a well and in a channel, and
the force a wall exerts against the energy's.

Usage:
    python benchmarks/confinement_figure.py [--out docs/confinement.png] [--steps 20000]

Left, middle: 256 cells at area fraction 0.9 (eta = 0.05, v0 = 0.05, D_r = 0.1, arc rule)
after ``--steps`` steps from the disordered start, in a well and in a channel of width
12 R0, coloured by shape index q (the wall drawn in black).  Right: the wall's force on a
circular cell whose centre lies d inside a straight wall, at K = 40 under the binary and
linear (arc) rules, against the exact chord 2 sqrt(R0^2 - d^2).  The numbers printed are the
largest depth of a contour point beyond the wall and the wall pressure of each snapshot.
About a minute on one core.
"""

from __future__ import annotations

import argparse

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import PolyCollection  # noqa: E402

from fcsweep.kernels.api import kernel_rates  # noqa: E402
from fcsweep.model.confinement import cell_contours, confinement_of, wall_gap, wall_pressure  # noqa: E402
from fcsweep.model.shape import shape_index  # noqa: E402
from fcsweep.simulation import Simulation  # noqa: E402


def snapshot(ax, boundary, size, steps):
    """Run one confined packing and draw it; return (largest depth beyond the wall, pressure)."""
    sim = Simulation.create(256, seed=4, eta=0.05, v0=0.05, Dr=0.1, density=0.9, boundary=boundary,
                            boundary_size=size, initial="disordered")
    sim.advance(steps)
    s, conf = sim.state, sim.confinement
    x, _, _ = cell_contours(s.pos, s.theta, s.a, s.b, K=80)
    q = shape_index(s.a, s.b)
    polys = PolyCollection(x, array=q, cmap="viridis", clim=(3.545, 3.9), edgecolor="k", linewidth=0.3)
    ax.add_collection(polys)
    if conf.kind == "well":
        ax.add_patch(plt.Circle(conf.centre, conf.size, fill=False, color="k", linewidth=1.5))
        lo, hi = conf.centre - conf.size - 1, conf.centre + conf.size + 1
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
    else:
        for y in (conf.y_lo, conf.y_hi):
            ax.axhline(y, color="k", linewidth=1.5)
        ax.set_xlim(0, conf.host[0])
        ax.set_ylim(conf.y_lo - 1, conf.y_hi + 1)
    ax.set_aspect("equal")
    ax.set_xticks([])
    ax.set_yticks([])
    depth = float(wall_gap(x, conf).max())
    pressure = wall_pressure(s.pos, s.theta, s.a, s.b, conf)
    ax.set_title(f"{boundary}: N = 256, area fraction {conf.area_fraction:.2f}\n"
                 f"deepest point beyond the wall {depth:.3f} R0, pressure {pressure:.3f}", fontsize=8)
    return polys, depth, pressure


def force_law(ax):
    """Wall force on a circular cell against the exact chord."""
    conf = confinement_of("channel", 10.0, 16, 0.5)
    d = np.linspace(0.05, 0.999, 120)
    ax.plot(d, 2 * np.sqrt(1 - d * d), "k-", label="exact: chord 2 sqrt(R0² - d²)")
    for quad, style in (("binary", "C3."), ("linear", "C0.")):
        f = [kernel_rates(np.array([[3.0, conf.y_lo + di]]), [0.3], np.zeros((1, 5)), np.zeros((1, 5)), eta=0.0,
                          v0=0.0, wall=conf, contour_points=40, quadrature=quad)["dpos"][0, 1] for di in d]
        ax.plot(d, f, style, markersize=3, label=f"K = 40, {quad if quad == 'binary' else 'linear / arc'} rule")
    ax.set_xlabel("centre inside the wall, d / R0")
    ax.set_ylabel("wall force on the cell (units of the overlap term)")
    ax.legend(fontsize=7)
    ax.set_title("a cell pressed against a wall", fontsize=8)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="docs/confinement.png")
    ap.add_argument("--steps", type=int, default=20000)
    args = ap.parse_args()
    fig, axes = plt.subplots(1, 3, figsize=(13, 4.3), gridspec_kw={"width_ratios": [1, 1.6, 1]})
    polys, dw, pw = snapshot(axes[0], "well", 0.0, args.steps)
    _, dc, pc = snapshot(axes[1], "channel", 12.0, args.steps)
    fig.colorbar(polys, ax=axes[:2], label="shape index q", shrink=0.7)
    force_law(axes[2])
    fig.savefig(args.out, dpi=130, bbox_inches="tight")
    print(f"well: deepest {dw:.4f} R0, pressure {pw:.4f}; channel: deepest {dc:.4f} R0, pressure {pc:.4f}; "
          f"wrote {args.out}")


if __name__ == "__main__":
    main()
