"""Check the cost model of ``fcsweep simulate --dry-run`` against real sweeps.

For each sweep: ``fcsweep simulate CONFIG --dry-run`` with an empty cost cache (it times
the step: :mod:`fcsweep.sweep.cost`), then ``fcsweep simulate CONFIG`` into a fresh
temporary directory (measured wall time of the command and CPU time of the child
process), then a second dry run (the cached cost) against a second fresh run.  Prints
estimate, measurement and their ratio; the issue asks for agreement within 25 %.  The
wall estimate assumes a free core per process: on a loaded machine the wall ratio
shows the load, the CPU ratio the model.

Usage:
    python benchmarks/cost_model.py                # the built-in demo and a 4-run N = 256 sweep
    python benchmarks/cost_model.py --repeats 2    # repeat the whole comparison
    python benchmarks/cost_model.py --config benchmarks/fig1c_cost_check.yaml --once
                                                   # a config of yours, one dry run and one sweep
"""

from __future__ import annotations

import argparse
import os
import re
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

N256 = """description: 4-run N = 256 sweep (cost-model check)
output: out
seed: 7
grid: {eta: [0.03, 0.1], v0: [0.03, 0.06]}
model: {N: 256, Dr: 0.01, dt: 0.005, modes: 6, contour_points: 40, quadrature: arc}
run: {steps: 4000, sample_every: 100, checkpoint_every: 1000, transient: 0.2}
"""
EXE = [sys.executable, "-m", "fcsweep.cli", "simulate"]
_UNIT = {"s": 1.0, "min": 60.0, "h": 3600.0}


def _seconds(text: str) -> float:
    value, unit = text.split()
    return float(value) * _UNIT[unit]


def estimate(args, cwd) -> tuple[float, float]:
    """(CPU, wall) seconds the dry run estimates."""
    env = {**os.environ, "FCSWEEP_COST_CACHE": str(Path(cwd) / "cost-cache")}
    out = subprocess.run(EXE + args + ["--dry-run"], cwd=cwd, capture_output=True, text=True, check=True,
                         env=env).stdout
    m = re.search(r"estimated (.+?) of CPU and about (.+?) of wall time", out)
    return _seconds(m.group(1)), _seconds(m.group(2))


def measure(args, cwd) -> tuple[float, float]:
    """(CPU, wall) seconds of ``fcsweep simulate`` (CPU of the child process)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(EXE + args + ["-q"], cwd=cwd, check=True, capture_output=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime), wall


def compare(name, args, cwd, out_opt, once=False):
    rows = []
    first = args + ["-o", out_opt + "_a"]
    est = estimate(first, cwd)
    got = measure(first, cwd)
    rows.append((f"{name}, timed now", est, got))
    if once:
        return rows
    # the second dry run reads the cost the first one cached
    est2 = estimate(first + ["--force"], cwd)
    got2 = measure(args + ["-o", out_opt + "_b"], cwd)
    rows.append((f"{name}, cached cost", est2, got2))
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=1)
    ap.add_argument("--config", nargs="+", help="check these configs instead of the two built-in sweeps")
    ap.add_argument("--once", action="store_true", help="one dry run and one sweep each (no cached-cost repeat)")
    a = ap.parse_args(argv)
    print(f"{'sweep':36} {'est CPU':>8} {'CPU':>8} {'ratio':>6} {'est wall':>9} {'wall':>8} {'ratio':>6}")
    for _ in range(a.repeats):
        with tempfile.TemporaryDirectory() as tmp:
            if a.config:
                rows = [r for i, c in enumerate(a.config)
                        for r in compare(Path(c).name, [str(Path(c).resolve())], tmp, f"c{i}", a.once)]
            else:
                Path(tmp, "n256.yaml").write_text(N256)
                rows = compare("demo (4 x N=36, 2000 steps)", [], tmp, "demo", a.once)
                rows += compare("4 x N=256, 4000 steps, arc", ["n256.yaml"], tmp, "n256", a.once)
        for label, (ec, ew), (c, w) in rows:
            print(f"{label:36} {ec:8.1f} {c:8.1f} {ec / c:6.2f} {ew:9.1f} {w:8.1f} {ew / w:6.2f}", flush=True)


if __name__ == "__main__":
    main()
