"""The physics check of the coexistence start (issue 45, item 1): at eta = 0.1, v0 = 0.01 the
crystal slab must read solid (grow or stay), at eta = 0.03, v0 = 0.06 not solid (melt).

N = 1024, D_r = 0.01, quadrature binary, dt = 5e-3, seed 1, 500 time units from
``initial: coexistence``; a frame every 5 time units.  Per point: the crystal fraction
curve (:func:`fcsweep.analysis.crystal.crystal_fraction`), its trend, the
``phase_coexistence`` label on the whole run and on its first T time units (the run length
the decision takes), and the CPU seconds of the start, the dynamics and the analysis.

    nice -n 10 python benchmarks/coexistence_check.py [--time 500] [--out benchmarks/results/coexistence_check.txt]
    python benchmarks/coexistence_check.py --from-saved   # labels again from the saved curves

Each point's curve is saved beside the results (``coexistence_eta<eta>_v0<v0>.txt``, its
header the CPU seconds), so ``--from-saved`` re-reads the labels without the runs.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from fcsweep.analysis.crystal import COEXISTENCE_FLAGS, SETTLE_TIME, crystal_fraction, crystal_trend, phase_coexistence
from fcsweep.model.lattice import lattice_box
from fcsweep.simulation import Simulation

POINTS = ((0.1, 0.01, "solid"), (0.03, 0.06, "not solid"))
COMMON = dict(Dr=0.01, quadrature="binary", dt=5e-3)


def run_point(eta: float, v0: float, *, N: int = 1024, seed: int = 1, duration: float = 500.0,
              every: float = 5.0) -> dict:
    """Run one coexistence start; the crystal fraction of each frame and the CPU it took."""
    c0 = time.process_time()
    sim = Simulation.create(N, seed=seed, eta=eta, v0=v0, initial="coexistence", **COMMON)
    c_start = time.process_time() - c0
    steps = int(round(every / sim.params.dt))
    frames, times = [sim.state.pos.copy()], [sim.time]
    c_sim = 0.0
    while sim.time < duration - 1e-9:
        c0 = time.process_time()
        sim.advance(steps)
        c_sim += time.process_time() - c0
        frames.append(sim.state.pos.copy())
        times.append(sim.time)
    c0 = time.process_time()
    f = crystal_fraction(np.array(frames), sim.state.box)
    c_ana = time.process_time() - c0
    return dict(t=np.array(times), f=f, box=sim.state.box.copy(), N=N, cpu_start=c_start, cpu_sim=c_sim,
                cpu_analysis=c_ana)


def report(eta, v0, expect, r) -> list[str]:
    t, f = r["t"], r["f"]
    lab = phase_coexistence(t, f, r["box"], r["N"])
    k = t >= SETTLE_TIME
    tr = crystal_trend(t[k], f[k])
    lines = [f"eta = {eta:g}, v0 = {v0:g} (expected {expect}): phase_coexistence = {COEXISTENCE_FLAGS[lab.code]} "
             f"at P = {lab.confidence:.3f} [{lab.reason_code}]",
             f"  {lab.reason}",
             f"  crystal fraction start {f[0]:.3f}, end {f[-1]:.3f}; mean {tr.mean:.3f} ± {tr.mean_err:.2g}, "
             f"slope {tr.slope:.3g} ± {tr.slope_err:.2g} per time unit (tau {tr.tau:.1f} frames, n_eff "
             f"{tr.n_eff:.1f}); residual sd {np.std(f[k] - tr.mean - tr.slope * (t[k] - t[k].mean())):.3g}",
             "  f(t): " + ", ".join(f"{ti:g}: {fi:.3f}" for ti, fi in zip(t, f) if ti % 25 < 1e-6)]
    first = None
    prefix = []
    for T in np.arange(50.0, t[-1] + 1e-9, 25.0):
        k = t <= T + 1e-9
        lk = phase_coexistence(t[k], f[k], r["box"], r["N"])
        prefix.append(f"{T:g}: {COEXISTENCE_FLAGS[lk.code]}")
        if lk.code == lab.code and first is None:
            first = T
        elif lk.code != lab.code:
            first = None
    lines.append("  label on the first T time units: " + ", ".join(prefix))
    lines.append(f"  decided (and kept to the end) from T = {first} time units")
    lines.append(f"  CPU s: start {r['cpu_start']:.1f}, dynamics {r['cpu_sim']:.1f} "
                 f"({r['N'] * (len(t) - 1) * round(5.0 / COMMON['dt']) / max(r['cpu_sim'], 1e-9):.3g} cell-steps/s), "
                 f"crystal fraction {r['cpu_analysis']:.1f} ({len(t)} frames)")
    return lines


def curve_path(out: Path, eta: float, v0: float) -> Path:
    return out.with_name(f"coexistence_eta{eta:g}_v0{v0:g}.txt")


def load_point(path: Path, N: int = 1024) -> dict:
    """A saved curve and the CPU seconds its header records."""
    header = path.read_text().splitlines()[0]
    cpu = dict(item.split("=") for item in header.lstrip("# ").split() if "=" in item)
    t, f = np.loadtxt(path, unpack=True)
    _, Lx, Ly = lattice_box(N, 0.95, 1.0)
    return dict(t=t, f=f, box=np.array([Lx, Ly]), N=N, **{k: float(v) for k, v in cpu.items()})


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--time", type=float, default=500.0)
    ap.add_argument("--out", default=str(Path(__file__).parent / "results" / "coexistence_check.txt"))
    ap.add_argument("--from-saved", action="store_true", help="read the saved curves instead of running")
    args = ap.parse_args(argv)
    out_path = Path(args.out)
    out = [f"# benchmarks/coexistence_check.py --time {args.time:g}: N = 1024, seed 1, {COMMON}, "
           "a frame every 5 time units, initial: coexistence (CPU: process time, numba's threads included)"]
    for eta, v0, expect in POINTS:
        if args.from_saved:
            r = load_point(curve_path(out_path, eta, v0))
        else:
            r = run_point(eta, v0, duration=args.time)
            cpu = " ".join(f"{k}={r[k]:.1f}" for k in ("cpu_start", "cpu_sim", "cpu_analysis"))
            np.savetxt(curve_path(out_path, eta, v0), np.column_stack([r["t"], r["f"]]), fmt="%.6g",
                       header=f"{cpu}\nt crystal_fraction")
        lines = report(eta, v0, expect, r)
        print("\n".join(lines), flush=True)
        out += lines
    out_path.write_text("\n".join(out) + "\n")


if __name__ == "__main__":
    main()
