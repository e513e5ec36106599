"""End-to-end cost against N: ``fcsweep simulate``, ``analyze`` and ``aggregate`` of one short run.

Called by ``python benchmarks/scaling.py --end-to-end`` (see there for the options).  For
each N (= n^2, n even: the hexagonal start) a config is written into a temporary
directory (the paper's model: v0 = 0.03, Dr = 0.01, eta = 0.1, density 0.95, M = 6,
40 contour points, binary quadrature; ``analysis.correlations: fft``) and the real CLI is
run in subprocesses, one thread each (``NUMBA_NUM_THREADS=1``, freud on one thread).
Each subprocess's own CPU time and peak RSS come from ``os.wait4`` (its rusage alone).

Recorded per N:

- ``sim cell-steps/s``: ``cell_steps / cpu_seconds`` of the run's ``status.json`` (the
  runner's own CPU time of the run, frames and checkpoints included, start-up excluded);
- ``sim RSS``, ``analyze RSS``: peak resident memory of the two commands;
- ``analyze CPU/frame``: (CPU of ``fcsweep analyze`` - CPU of its start-up, measured as a
  second ``fcsweep analyze`` that finds the run up to date) / frames analysed; every
  analysed frame of such a short run is a structure, shape and correlation frame (all
  observables), and the run's fixed costs (fits, MSD, cage) are counted in it too;
- ``MSD+D 401``, ``cage 401``: CPU of the streamed MSD curve and D_eff, and of the cage
  measure (a Voronoi tessellation at each of its time origins), for 401 analysed frames
  (a 501-frame run after its 20 % transient), on a synthetic random walk of N cells
  (0.02 R0 per coordinate and frame: the cages hold, so no lags are added past t*) held in
  memory (``--msd-max`` caps N);
- ``traj B/frame``, ``checkpoint B``: trajectory.h5 bytes per frame (gzip 4, all fields)
  and the size of the run's checkpoint file;
- ``aggregate s``: CPU of ``fcsweep aggregate`` (one run).

The extrapolation to a run of 200 000 steps with a frame every 400 (501 frames) is
``simulation = N * 200000 / (cell-steps/s)`` and ``analysis = start-up + 100 structure
frames * CPU/frame + MSD+D 401 + cage 401``: an upper bound, since each structure frame
is counted at the cost of a frame with every observable and the run's fixed costs, while
only 10 get the correlations.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

CONFIG = """description: end-to-end scaling benchmark, N = {N}
output: {out}
seed: 11
replicates: 1
grid:
  eta: [0.1]
model:
  N: {N}
  v0: 0.03
  Dr: 0.01
  density: 0.95
  dt: 0.005
  modes: 6
  contour_points: 40
  quadrature: binary
run:
  steps: {steps}
  sample_every: {every}
  checkpoint_every: {steps}
  transient: 0.2
analysis:
  correlations: fft
"""


def _env() -> dict:
    env = dict(os.environ)
    env.update(PYTHONPATH=str(ROOT), NUMBA_NUM_THREADS="1", OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1",
               MKL_NUM_THREADS="1")
    return env


def run_cli(*args) -> dict:
    """One ``fcsweep`` command in a subprocess: its wall and CPU seconds and peak RSS (bytes)."""
    t0 = time.perf_counter()
    p = subprocess.Popen([sys.executable, "-m", "fcsweep.cli", *args], env=_env(), stdout=subprocess.PIPE,
                         stderr=subprocess.STDOUT)
    out = p.stdout.read().decode(errors="replace")
    _, status, ru = os.wait4(p.pid, 0)
    p.returncode = os.waitstatus_to_exitcode(status)
    if p.returncode != 0:
        raise RuntimeError(f"fcsweep {' '.join(args)} failed ({p.returncode}):\n{out[-3000:]}")
    return {"wall": time.perf_counter() - t0, "cpu": ru.ru_utime + ru.ru_stime, "rss": ru.ru_maxrss * 1024,
            "out": out}


def msd_cost(N: int, T: int = 401, seed: int = 0) -> tuple[float, float]:
    """CPU seconds of the streamed MSD curve and D_eff, and of the cage measure, on ``T``
    frames of a random walk of ``N`` cells on a lattice (lengths in R0, frames 2 time units
    apart)."""
    from fcsweep.analysis.cage import cage_breaking
    from fcsweep.analysis.diffusion import estimate_diffusion
    from fcsweep.analysis.frames import ArrayFrames
    from fcsweep.analysis.msd import msd_curve_streamed
    from fcsweep.model.lattice import hexagonal_lattice

    lattice, box = hexagonal_lattice(N)
    rng = np.random.default_rng(seed)
    x = np.cumsum(0.02 * rng.standard_normal((T, N, 2)), axis=0)
    x += lattice[None]
    t = np.arange(T) * 2.0
    src = ArrayFrames(x)
    c0 = time.process_time()
    msd_curve_streamed(src)
    estimate_diffusion(t, src, Dr=0.01)
    c1 = time.process_time()
    cage_breaking(t, src, np.asarray(box, dtype=float))
    return c1 - c0, time.process_time() - c1


def measure(N: int, *, steps: int, every: int, msd_max: int, keep: Path | None = None) -> dict:
    """Simulate, analyse and aggregate one run of ``N`` cells; the numbers of the module doc."""
    work = Path(tempfile.mkdtemp(prefix=f"fcsweep_e2e_{N}_", dir=keep))
    cfg = work / "config.yaml"
    cfg.write_text(CONFIG.format(N=N, out=work / "runs", steps=steps, every=every))
    sim = run_cli("simulate", "-q", str(cfg))
    rd = next((work / "runs").glob("**/status.json")).parent
    status = json.loads((rd / "status.json").read_text())
    ana = run_cli("analyze", str(cfg))
    start = run_cli("analyze", str(cfg))  # up to date: the start-up alone
    agg = run_cli("aggregate", str(cfg))
    import h5py

    with h5py.File(rd / "trajectory.h5", "r") as f:
        n_frames = int(f["particles/cells/position/value"].shape[0])
    with h5py.File(rd / "analysis.h5", "r") as f:
        analysed = int(f["frames"].shape[0])
    ckpt = [p for p in rd.iterdir() if "checkpoint" in p.name]
    out = {"N": N, "steps": steps, "frames": n_frames, "analysed": analysed,
           "sim_rate": float(status["cell_steps"]) / float(status["cpu_seconds"]),
           "sim_cpu": sim["cpu"], "sim_rss": sim["rss"], "ana_cpu": ana["cpu"], "ana_rss": ana["rss"],
           "ana_start": start["cpu"],
           "agg_cpu": agg["cpu"], "traj_per_frame": (rd / "trajectory.h5").stat().st_size / n_frames,
           "checkpoint": sum(p.stat().st_size for p in ckpt) if ckpt else float("nan"),
           "msd401": float("nan"), "cage401": float("nan")}
    if N <= msd_max:
        out["msd401"], out["cage401"] = msd_cost(N)
    if keep is None:
        import shutil

        shutil.rmtree(work, ignore_errors=True)
    return out


def table(results) -> str:
    """The measured rows and the extrapolation to a 501-frame, 200 000-step run."""
    lines = [f"{'N':>7} {'frames':>6} {'sim cs/s':>9} {'sim RSS':>8} {'ana CPU/fr':>10} {'ana RSS':>8} "
             f"{'MSD+D 401':>9} {'cage 401':>8} {'traj B/fr':>10} {'ckpt B':>9} {'agg s':>6} | "
             f"{'sim 501 s':>9} {'ana 501 s':>9} {'ana/sim':>7}"]
    for r in results:
        per_frame = (r["ana_cpu"] - r["ana_start"]) / r["analysed"]
        sim501 = r["N"] * 200000 / r["sim_rate"]
        ana501 = r["ana_start"] + 100 * per_frame + r["msd401"] + r["cage401"]
        lines.append(f"{r['N']:>7d} {r['frames']:>6d} {r['sim_rate']:>9.3g} {r['sim_rss'] / 2**20:>6.0f}MB "
                     f"{per_frame:>10.3g} {r['ana_rss'] / 2**20:>6.0f}MB {r['msd401']:>9.3g} {r['cage401']:>8.3g} "
                     f"{r['traj_per_frame']:>10.3g} {r['checkpoint']:>9.3g} {r['agg_cpu']:>6.2f} | "
                     f"{sim501:>9.3g} {ana501:>9.3g} {ana501 / sim501:>7.3f}")
    lines.append("CPU seconds and bytes; sim cs/s: cell-steps per CPU-second, one thread; RSS: peak of the "
                 "command; 501-frame columns extrapolated as in benchmarks/end_to_end.py (analysis: an upper bound)")
    return "\n".join(lines)


def main(sizes, *, steps: int, every: int, msd_max: int, out=None, keep=None) -> None:
    results = []
    for N in sizes:
        r = measure(N, steps=steps, every=every, msd_max=msd_max, keep=keep)
        results.append(r)
        print(json.dumps(r), flush=True)
    text = table(results)
    print(text)
    if out:
        Path(out).write_text(text + "\n")
