"""Figure of docs/model.md's adhesion paragraph: an adhered pair against the energy.

Usage:
    python benchmarks/adhesion_figure.py [--out docs/adhesion.png]

Left: two rigid discs relaxed at v0 = 0 with the kernels (K = 320, delta = 0.1 R0) against
the contact the continuum energy predicts (the lens chord balancing the adhesion pull).
Middle: two deformable cells (M = 6, eta = 0.1, K = 40): the adhered length L = -E_adh/gamma
of the relaxed pair, which must grow with gamma.  Right: the relaxed deformable pairs
contours.  About a minute on one core.
"""

from __future__ import annotations

import argparse

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from scipy.optimize import brentq  # noqa: E402

from fcsweep.kernels.api import kernel_rates  # noqa: E402
from fcsweep.model.adhesion import adhesion_energy, smooth_step  # noqa: E402
from fcsweep.model.shape import radius  # noqa: E402


def disc_chord(gamma, delta):
    """Chord of two adhered discs from the continuum energy's force balance."""
    phi = np.linspace(-np.pi, np.pi, 200001)

    def residual(d):
        dist = np.sqrt(1 + d * d - 2 * d * np.cos(phi))
        _, dw = smooth_step(dist - 1, delta)
        return 2 * np.sqrt(max(1 - d * d / 4, 0.0)) + 2 * gamma * np.trapezoid(dw * (d - np.cos(phi)) / dist, phi)

    d = brentq(residual, 1.5, 2.0)
    return 2 * np.sqrt(1 - d * d / 4)


def relax(gamma, delta, K, M1, eta, steps, dt, d0=2.05):
    pos = np.array([[0.0, 0.0], [d0, 0.0]])
    th = np.array([0.0, np.pi])
    a = np.zeros((2, M1))
    b = np.zeros((2, M1))
    for _ in range(steps):
        r = kernel_rates(pos, th, a, b, eta=eta, v0=0.0, contour_points=K, adhesion=gamma, adhesion_range=delta)
        pos += dt * r["dpos"]
        th += dt * r["dtheta"]
        a += dt * r["da"]
        b += dt * r["db"]
    return pos, th, a, b


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default="docs/adhesion.png")
    args = ap.parse_args(argv)
    fig, ax = plt.subplots(1, 3, figsize=(12, 3.6))
    g = np.linspace(0.01, 0.3, 30)
    ax[0].plot(g, [disc_chord(x, 0.1) for x in g], "-", label="energy balance (continuum)")
    pts = [0.02, 0.05, 0.1, 0.2, 0.3]
    chords = []
    for x in pts:
        pos, *_ = relax(x, 0.1, 320, 0, 0.0, 2000, 2e-3)
        d = np.hypot(*(pos[1] - pos[0]))
        chords.append(2 * np.sqrt(1 - d * d / 4))
        print(f"discs gamma={x:g}: chord {chords[-1]:.4f} (energy {disc_chord(x, 0.1):.4f})", flush=True)
    ax[0].plot(pts, chords, "o", label="kernel, relaxed (K = 320)")
    ax[0].set(xlabel="adhesion γ", ylabel="contact chord / R0", title="rigid discs, δ = 0.1 R0")
    ax[0].legend(fontsize=8)
    gs = [0.0, 0.02, 0.05, 0.1]
    Ls = []
    phi = np.linspace(0, 2 * np.pi, 400)
    for x, c in zip(gs, ("k", "C0", "C1", "C3")):
        pos, th, a, b = relax(x, 0.1, 40, 5, 0.1, 1500, 5e-3)
        L = -adhesion_energy(pos, th, a, b, adhesion=1.0, adhesion_range=0.1, contour_points=40)
        Ls.append(L)
        print(f"deformable gamma={x:g}: distance {np.hypot(*(pos[1] - pos[0])):.4f}, adhered length {L:.4f}",
              flush=True)
        for i in range(2):
            R, _ = radius(phi, a[i], b[i])
            ax[2].plot(pos[i, 0] + R * np.cos(phi + th[i]), pos[i, 1] + R * np.sin(phi + th[i]), c, lw=1,
                       label=f"γ = {x:g}" if i == 0 else None)
    ax[1].plot(gs, Ls, "o-")
    ax[1].set(xlabel="adhesion γ", ylabel="adhered length L / R0 (both cells)",
              title="deformable pair, η = 0.1, M = 6")
    ax[2].set_aspect("equal")
    ax[2].set(xlim=(-1.1, 3.2), ylim=(-1.15, 1.15), title="relaxed pairs (cell 1 at the origin)")
    ax[2].legend(fontsize=7, loc="upper right")
    fig.tight_layout()
    fig.savefig(args.out, dpi=110)
    print("wrote", args.out)


if __name__ == "__main__":
    main()
