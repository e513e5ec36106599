"""Cost per simulated time unit at fixed accuracy, for each quadrature x integrator (issue 16).

Usage: python benchmarks/integrators.py [--quick] [--outdir DIR]

Four measurements, all at rho = 0.95, K = 40, M = 6:

1. **Contact persistence** at the issue's two states (eta, v0) = (0.03, 0.06) and
   (0.1, 0.01), N = 64, D_r = 0.1, 5 time units off the lattice: of the pairs whose exact
   overlap area (``overlap_exact.overlap_areas``) is positive at one instant, the fraction
   still overlapping 0.01 time units later (one step at dt = 0.01), pooled over 10
   intervals; and the mean total overlap area.  The first row of each state is arc +
   Euler at dt = 2.5e-4, the converged dynamics sampled at the same interval.
2. **Trajectory error** with D_r = 0 (deterministic), N = 64 from the lattice, T = 2:
   rms over cells of the unwrapped centroid difference to arc + Euler at dt = 3e-4 (the
   converged reference of the model's exact-overlap forces), at (eta, v0) = (0.03, 0.06).
3. **Observables** ⟨q⟩, rho_d, MSD(lag 10) at eta = 0.03, v0 = 0.06, D_r = 0.01, N = 144:
   every setting continues the same equilibrated states (arc, Euler, dt = 5e-3) with the
   same noise stream for ``obs_T`` time units; Δ is the paired mean difference to the
   reference (arc, Euler, dt = 1.25e-3), ± its sem over seeds.
4. **Cost**: process CPU seconds per cell-step of ``Simulation.advance`` at N = 1024
   (one numba thread, after 2000 steps off the lattice, best of 3 interleaved repeats);
   cost per time unit = cost per step / dt.

"Fixed accuracy" is the accuracy of today's default (arc, Euler, dt = 5e-3): a setting
qualifies at a dt when its trajectory error is no larger than that default's and its
observable shifts are within ``tolerance`` (|Δ⟨q⟩| <= 0.005, |Δrho_d| <= 0.02, |ΔMSD|
<= 10 % of the reference, or within twice their paired sem).  The table gives, per
quadrature x integrator, the largest such dt of the ladder and the cost per time unit
there.

Outputs (in --outdir, default benchmarks/results; --quick writes to a temporary
directory unless --outdir is given): integrators.txt (tables), integrators.json.
"""

from __future__ import annotations

import argparse
import json
import math
import pathlib
import sys
import tempfile
import time

import numba
import numpy as np

from fcsweep.model.integrators import contact_persistence, integrator_problem
from fcsweep.model.overlap_exact import candidate_pairs, overlap_areas
from fcsweep.simulation import INTEGRATORS, Simulation, SimulationError

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from speed_vs_error import equilibrated, fork, observe  # noqa: E402

QUADS = ("binary", "arc")
#: Interval (time units) between the contact sets of the persistence measurement: one
#: step at dt = 0.01, several at smaller dt (the converged reference is sampled alike).
P_INTERVAL = 0.01
TOL = {"q": 0.005, "rho_d": 0.02, "msd_rel": 0.10}


def config(quick):
    if quick:
        return {"quick": True, "p_states": ((0.03, 0.06),), "p_T": 1.0, "p_ref_dt": 2.5e-3, "traj_T": 0.5, "traj_ref_dt": 2.5e-3,
                "dts": (0.01, 0.02), "default_dt": 0.01, "obs_N": 16, "obs_seeds": 2, "obs_eq": 1.0,
                "obs_T": 1.0, "obs_skip": 0.2, "obs_sample": 0.2, "obs_lag": 0.4, "obs_ref_dt": 5e-3,
                "cost_N": 64, "cost_warm": 50, "cost_steps": 20}
    return {"quick": False, "p_states": ((0.03, 0.06), (0.1, 0.01)), "p_T": 5.0, "p_ref_dt": 2.5e-4, "traj_T": 2.0,
            "traj_ref_dt": 3e-4, "dts": (0.0025, 0.005, 0.01, 0.02), "default_dt": 0.005,
            "obs_N": 144, "obs_seeds": 4, "obs_eq": 30.0, "obs_T": 30.0, "obs_skip": 5.0, "obs_sample": 0.2,
            "obs_lag": 10.0, "obs_ref_dt": 1.25e-3, "cost_N": 1024, "cost_warm": 2000, "cost_steps": 60}


def settings():
    """Every quadrature x integrator pair that can run (contact-jacobi needs arc)."""
    return [(q, integ) for q in QUADS for integ in INTEGRATORS if integrator_problem(integ, q, 6) is None]


def overlap_total(sim):
    """Sum of the exact overlap areas of all pairs (R0²) and the set of overlapping pairs."""
    s = sim.state
    i, j, d = candidate_pairs(s.pos, s.a, s.b, box=sim.params.box)
    area = overlap_areas(d, s.theta[i], s.a[i], s.b[i], s.theta[j], s.a[j], s.b[j], resolution=1024)
    hit = area > 0.0
    return float(area[hit].sum()), set(zip(i[hit].tolist(), j[hit].tolist()))


# ----------------------------------------------------------------------------- parts
def persistence(cfg, log):
    out = {}
    for eta, v0 in cfg["p_states"]:
        runs = [("arc", "euler", cfg["p_ref_dt"])] + [(q, i, dt) for q, i in settings() for dt in (0.005, 0.01)]
        for q, integ, dt in runs:
            sim = Simulation.from_lattice(64, eta=eta, v0=v0, Dr=0.1, seed=3, dt=dt, quadrature=q,
                                          integrator=integ)
            sim.advance(int(round(cfg["p_T"] / dt)))
            sets, areas = [], []
            for _ in range(11):
                area, pairs = overlap_total(sim)
                sets.append(pairs)
                areas.append(area)
                sim.advance(int(round(P_INTERVAL / dt)))
            key = f"eta={eta:g} v0={v0:g} {q} {integ} dt={dt:g}"
            out[key] = {"eta": eta, "v0": v0, "quadrature": q, "integrator": integ, "dt": dt,
                        "persistence": contact_persistence(sets),
                        "contacts": float(np.mean([len(x) for x in sets])), "area": float(np.mean(areas))}
        log(f"  persistence eta={eta:g} v0={v0:g} done")
    return out


def trajectories(cfg, log, eta=0.03, v0=0.06):
    def final(q, integ, dt):
        sim = Simulation.from_lattice(64, eta=eta, v0=v0, Dr=0.0, seed=5, dt=dt, quadrature=q, integrator=integ)
        sim.advance(int(round(cfg["traj_T"] / dt)))
        return sim.state.unwrapped()

    ref = final("arc", "euler", cfg["traj_ref_dt"])
    out = {}
    for q, integ in settings():
        for dt in cfg["dts"]:
            try:
                x = final(q, integ, dt)
                out[f"{q} {integ} {dt:g}"] = float(np.sqrt(np.mean(np.sum((x - ref) ** 2, axis=1))))
            except SimulationError:
                out[f"{q} {integ} {dt:g}"] = float("inf")
        log(f"  trajectories {q} {integ} done")
    return out


def observables(cfg, log):
    eta, v0 = 0.03, 0.06
    bases = [equilibrated(cfg["obs_N"], eta, v0, 100 + s, cfg["obs_eq"], quadrature="arc")
             for s in range(cfg["obs_seeds"])]
    keys = [("arc", "euler", cfg["obs_ref_dt"])] + [(q, i, dt) for q, i in settings() for dt in cfg["dts"]
                                                    if dt >= 0.005 or cfg["quick"]]
    raw = {}
    for q, integ, dt in keys:
        rows = []
        for r, base in enumerate(bases):
            sim = fork(base, seed=1000 + r, quadrature=q, dt=dt, integrator=integ)
            rows.append(observe(sim, cfg["obs_T"], cfg["obs_skip"], cfg["obs_sample"], cfg["obs_lag"]))
        raw[f"{q} {integ} {dt:g}"] = rows
        log(f"  observables {q} {integ} dt={dt:g} done")
    ref = raw[f"arc euler {cfg['obs_ref_dt']:g}"]
    out = {}
    for key, rows in raw.items():
        row = {}
        for obs in ("q", "rho_d", "msd"):
            d = np.array([r[obs] for r in rows]) - np.array([r[obs] for r in ref])
            row[obs] = float(np.mean([r[obs] for r in rows]))
            row[obs + "_delta"] = float(d.mean())
            row[obs + "_delta_sem"] = float(d.std(ddof=1) / math.sqrt(len(d))) if len(d) > 1 else float("nan")
        out[key] = row
    return out


def cost(cfg, log):
    best = {}
    sims = {}
    for q, integ in settings():
        sim = Simulation.from_lattice(cfg["cost_N"], eta=0.03, v0=0.06, Dr=0.01, seed=1, quadrature=q,
                                      integrator=integ)
        sim.advance(cfg["cost_warm"])
        sims[(q, integ)] = sim
    threads = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        for _ in range(3):  # interleaved repeats: machine load affects all settings alike
            for key, sim in sims.items():
                t0 = time.process_time()
                sim.advance(cfg["cost_steps"])
                us = 1e6 * (time.process_time() - t0) / (cfg["cost_N"] * cfg["cost_steps"])
                best[key] = min(best.get(key, np.inf), us)
    finally:
        numba.set_num_threads(threads)
    log("  cost done")
    return {f"{q} {integ}": v for (q, integ), v in best.items()}


# ----------------------------------------------------------------------------- report
def qualifies(obs_row, err, err_target):
    if not err <= err_target:
        return False
    for name, tol in (("q", TOL["q"]), ("rho_d", TOL["rho_d"])):
        d, sem = obs_row[name + "_delta"], obs_row[name + "_delta_sem"]
        if abs(d) > max(tol, 2.0 * sem if math.isfinite(sem) else 0.0):
            return False
    d, sem = obs_row["msd_delta"], obs_row["msd_delta_sem"]
    return abs(d) <= max(TOL["msd_rel"] * abs(obs_row["msd"] - d), 2.0 * sem if math.isfinite(sem) else 0.0)


def tables(res, cfg):
    L = ["# Integrators: cost per time unit at fixed accuracy (benchmarks/integrators.py"
         + (" --quick" if cfg["quick"] else "") + ")", ""]
    L.append(f"## Contact persistence (fraction of overlapping pairs still overlapping {P_INTERVAL:g} time units "
             f"later) and total overlap area (R0²); the first row of each state is the converged reference")
    L.append(f"{'state':<16} {'quadrature':<8} {'integrator':<17} {'dt':>7} {'persistence':>11} {'contacts':>8} "
             f"{'area':>7}")
    for r in res["persistence"].values():
        L.append(f"eta={r['eta']:<5g} v0={r['v0']:<5g} {r['quadrature']:<8} {r['integrator']:<17} {r['dt']:>7g} "
                 f"{r['persistence']:>11.3f} {r['contacts']:>8.1f} {r['area']:>7.4f}")
    L += ["", f"## Trajectory error (rms centroid, R0) at T = {cfg['traj_T']:g}, D_r = 0, N = 64, "
          f"against arc + euler dt = {cfg['traj_ref_dt']:g}"]
    L.append(f"{'quadrature':<8} {'integrator':<17} " + " ".join(f"{'dt=' + format(d, 'g'):>11}" for d in cfg["dts"]))
    for q, integ in settings():
        L.append(f"{q:<8} {integ:<17} " + " ".join(f"{res['traj'][f'{q} {integ} {d:g}']:>11.2e}"
                                                   for d in cfg["dts"]))
    ref = res["obs"][f"arc euler {cfg['obs_ref_dt']:g}"]
    L += ["", f"## Observables at eta = 0.03, v0 = 0.06, N = {cfg['obs_N']}, {cfg['obs_seeds']} seeds: paired "
          f"differences to arc + euler dt = {cfg['obs_ref_dt']:g} (<q> = {ref['q']:.4f}, rho_d = "
          f"{ref['rho_d']:.3f}, MSD = {ref['msd']:.4f})"]
    L.append(f"{'setting':<32} {'d<q>':>18} {'d rho_d':>18} {'d MSD':>18}")
    for key, r in res["obs"].items():
        cells = [f"{r[o + '_delta']:+.4f} ± {r[o + '_delta_sem']:.4f}" for o in ("q", "rho_d", "msd")]
        L.append(f"{key:<32} " + " ".join(f"{c:>18}" for c in cells))
    target = res["traj"][f"arc euler {cfg['default_dt']:g}"]
    L += ["", f"## Cost per time unit at the accuracy of arc + euler dt = {cfg['default_dt']:g} "
          f"(trajectory error <= {target:.2e}; |d<q>| <= {TOL['q']}, |d rho_d| <= {TOL['rho_d']}, "
          f"|d MSD| <= {TOL['msd_rel']:.0%} or 2 sem)"]
    L.append(f"{'quadrature':<8} {'integrator':<17} {'us/cell-step':>12} {'largest dt':>10} "
             f"{'us/(cell*time)':>14} {'vs default':>10}")
    default_cost = res["cost"]["arc euler"] / cfg["default_dt"]
    for q, integ in settings():
        ok = [d for d in cfg["dts"] if f"{q} {integ} {d:g}" in res["obs"]
              and qualifies(res["obs"][f"{q} {integ} {d:g}"], res["traj"][f"{q} {integ} {d:g}"], target)]
        us = res["cost"][f"{q} {integ}"]
        if ok:
            per_t = us / max(ok)
            L.append(f"{q:<8} {integ:<17} {us:>12.3f} {max(ok):>10g} {per_t:>14.1f} {per_t / default_cost:>10.2f}")
        else:
            L.append(f"{q:<8} {integ:<17} {us:>12.3f} {'none':>10} {'-':>14} {'-':>10}")
    return "\n".join(L) + "\n"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="tiny version of every part (< 1 min)")
    ap.add_argument("--outdir", type=pathlib.Path, default=None)
    args = ap.parse_args(argv)
    cfg = config(args.quick)
    outdir = args.outdir or (pathlib.Path(tempfile.mkdtemp(prefix="fcsweep_int_")) if args.quick
                             else pathlib.Path(__file__).resolve().parent / "results")
    outdir.mkdir(parents=True, exist_ok=True)
    t0 = time.time()

    def log(msg):
        print(f"[{time.time() - t0:7.1f} s] {msg}", file=sys.stderr, flush=True)

    res = {"persistence": persistence(cfg, log), "traj": trajectories(cfg, log), "obs": observables(cfg, log),
           "cost": cost(cfg, log)}
    (outdir / "integrators.json").write_text(json.dumps({"config": cfg, "results": res}, indent=1, default=str))
    text = tables(res, cfg)
    (outdir / "integrators.txt").write_text(text)
    print(text)
    log(f"wrote {outdir}")


if __name__ == "__main__":
    main()
