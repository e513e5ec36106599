"""Figure of the end-to-end scaling table: cost and memory per command against N.

    python benchmarks/plot_scaling.py [benchmarks/results/scaling_end_to_end.txt] [docs/scaling_end_to_end.png]

Reads the table `benchmarks/scaling.py --end-to-end` writes and draws, against N on log
axes, (left) the CPU seconds of one simulation step of all cells, of one analysed frame,
and the extrapolated analysis / simulation ratio of a 501-frame, 200 000-step run, and
(middle) the peak RSS of simulate and analyze and the bytes per trajectory frame, with the
slope-1 line through the first point (linear in N) for reference; and, where
`benchmarks/results/scaling_threads.txt` (`scaling.py --threads`) is there, (right) the
step's wall-clock cell-steps per second at 1 and 2 threads.
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent


def read_table(path: Path) -> dict:
    """Columns of the measured rows (N, sim cs/s, sim RSS MB, analyze CPU-s per frame,
    analyze RSS MB, trajectory bytes per frame, analysis / simulation at 501 frames)."""
    rows = []
    for line in path.read_text().splitlines():
        parts = line.split()
        if parts and parts[0].isdigit():
            rows.append(parts)
    col = lambda i, strip="": np.array([float(r[i].replace(strip, "")) if strip else float(r[i])  # noqa: E731
                                        for r in rows])
    return {"N": col(0), "sim_rate": col(2), "sim_rss": col(3, "MB"), "ana_frame": col(4),
            "ana_rss": col(5, "MB"), "traj": col(8), "ratio": col(-1)}


def read_threads(path: Path) -> dict | None:
    """N and cell-steps/s at 1 and 2 threads of the thread table, or None without the file."""
    if not path.exists():
        return None
    rows = [line.split() for line in path.read_text().splitlines() if line.split() and line.split()[0].isdigit()]
    return {"N": np.array([float(r[0]) for r in rows]), 1: np.array([float(r[2]) for r in rows]),
            2: np.array([float(r[3]) for r in rows])}


def plot(t: dict, out: Path, threads: dict | None = None) -> None:
    N = t["N"]
    fig, axes = plt.subplots(1, 3 if threads else 2, figsize=(10.5 if threads else 7.0, 3.0), constrained_layout=True)
    a, b = axes[:2]
    a.loglog(N, N / t["sim_rate"], "o-", label="simulate: CPU-s per step")
    a.loglog(N, t["ana_frame"], "s-", label="analyze: CPU-s per frame")
    a.loglog(N, t["ratio"], "^--", label="analysis / simulation, 501 frames")
    a.loglog(N, N / N[0] * (N[0] / t["sim_rate"][0]), ":", color="0.5", label="linear in N")
    a.axhline(0.1, color="0.7", lw=0.8)
    a.set_xlabel("N (cells)")
    a.set_ylabel("CPU seconds / ratio")
    a.legend(fontsize=7)
    b.loglog(N, t["sim_rss"] / 1024, "o-", label="simulate peak RSS (GB)")
    b.loglog(N, t["ana_rss"] / 1024, "s-", label="analyze peak RSS (GB)")
    b.loglog(N, t["traj"] / 2**30, "^-", label="trajectory per frame (GB)")
    b.loglog(N, N / N[0] * t["traj"][0] / 2**30, ":", color="0.5", label="linear in N")
    b.set_xlabel("N (cells)")
    b.set_ylabel("GB")
    b.legend(fontsize=7)
    if threads:
        c = axes[2]
        for k, mark in ((1, "o-"), (2, "s-")):
            c.semilogx(threads["N"], threads[k], mark, label=f"{k} thread{'s' if k > 1 else ''}")
        c.set_ylim(0, None)
        c.set_xlabel("N (cells)")
        c.set_ylabel("step: cell-steps per second (wall)")
        c.legend(fontsize=7)
    fig.savefig(out, dpi=150)


if __name__ == "__main__":
    src = Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "benchmarks/results/scaling_end_to_end.txt"
    dst = Path(sys.argv[2]) if len(sys.argv) > 2 else ROOT / "docs/scaling_end_to_end.png"
    plot(read_table(src), dst, read_threads(ROOT / "benchmarks/results/scaling_threads.txt"))
    print(dst)
