"""Speed against error: contour quadrature (binary / linear / arc), K and dt (issue 5).

Usage: python benchmarks/speed_vs_error.py [--quick] [--outdir DIR] [--parts 1 2 3]

Three studies, all at rho = 0.95, M = 6:

1. **Force error vs K.**  Overlap rates (eta = 0, v0 = 0, so only the quadrature part
   is compared) of the numba kernels against ``continuum_rates`` (exact overlap arcs,
   the K -> inf limit) on dense snapshots: a fluid state (eta = 0.03, v0 = 0.03), a
   soft-fluid state (eta = 0.01, v0 = 0.06, shapes near the admissibility bound), both
   taken from simulations started on the lattice, and a synthetic jittered lattice
   (``dense_snapshot``, Σ|c_n| = 0.15).  With ΔF_i = F_i − F_ref,i and the scale
   S = sqrt(mean_i |F_ref,i|²):
       force error (rms) = sqrt(mean_i |ΔF_i|²) / S,
       force error (median, max) = median_i, max_i of |ΔF_i| / S,
       imbalance = |Σ_i F_i| / max_i |F_i|   (action-reaction; 0 in the continuum),
       torque / shape error = rms over cells (and modes) of the rate difference divided
       by the rms of the reference rate.
   Cost: cell-steps/s of ``Simulation`` at N = 1024 (after leaving the lattice), for
   every (quadrature, K), serial (one numba thread), measured as *process CPU time*
   (the machine is shared; wall time there varies 10x, CPU time a few %), best of 3
   interleaved repeats; ratios are to binary K = 40 of the same run.
2. **Trajectory error vs dt** with D_r = 0 (deterministic active dynamics, θ fixed by
   the state), quadrature arc and binary at K = 40, from equilibrated states of three
   scenes (fluid, soft-fluid, hard eta = 0.001 / v0 = 0.2), over a fixed time T; error =
   rms over cells of the unwrapped centroid difference to the run at the reference dt.
   Also arc K = 160, whose rates are smooth enough to show the integrator's own order;
   at K = 40 contacts appear and vanish discontinuously and set an error floor.
   Largest stable dt: a doubling ladder from 5e-3 (with D_r = 0.01); a dt passes when
   it raises no ``SimulationError`` and keeps ⟨q⟩ (second half of the run) within 5 %
   of the run at dt = 2.5e-3; the answer is the last pass before the first failure.
3. **Observables** ⟨q⟩, rho_d and MSD(lag) at the paper's critical point eta = 0.03,
   v0 = 0.06, D_r = 0.01, N = 144, for several (quadrature, K, dt), three seeds each.
   Every replicate starts from the same equilibrated state (binary, K = 40, dt = 5e-3)
   for all settings and uses the same noise stream, so differences to the finest
   setting (arc, K = 80, dt = 2.5e-3) are paired per seed.

Outputs (in --outdir, default benchmarks/results; --quick writes to a temporary
directory unless --outdir is given): speed_vs_error.txt (tables), speed_vs_error.json
(raw numbers), work_precision.png / .pdf.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import pathlib
import sys
import tempfile
import time

import numba
import numpy as np

from fcsweep.analysis.msd import msd_curve
from fcsweep.analysis.shapes import shape_indices
from fcsweep.analysis.voronoi import defect_statistics
from fcsweep.kernels.api import kernel_rates
from fcsweep.model.overlap_exact import continuum_rates
from fcsweep.simulation import Simulation, SimulationError

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from snapshots import dense_snapshot  # noqa: E402

QUADS = ("binary", "linear", "arc")
SCENES = {"fluid": (0.03, 0.03), "soft-fluid": (0.01, 0.06), "hard": (0.001, 0.2)}


# ----------------------------------------------------------------------------- helpers
def equilibrated(N, eta, v0, seed, t_eq, *, dt=5e-3, Dr=0.01, quadrature="binary", K=40):
    """A Simulation started on the lattice and run for time ``t_eq``."""
    sim = Simulation.from_lattice(N, eta=eta, v0=v0, Dr=Dr, seed=seed, dt=dt, contour_points=K,
                                  quadrature=quadrature)
    sim.advance(int(round(t_eq / dt)))
    return sim


def copy_state(state):
    """Deep copy of a ``State`` (step and projection counters reset)."""
    return dataclasses.replace(state, pos=state.pos.copy(), image=state.image.copy(),
                               theta=state.theta.copy(), a=state.a.copy(), b=state.b.copy(),
                               box=state.box.copy(), step=0, projections=0)


def fork(sim, *, seed=None, **changes):
    """A new Simulation from ``sim``'s current state with changed parameters."""
    p = dataclasses.replace(sim.params, **changes)
    rng = np.random.Generator(np.random.PCG64(p.seed if seed is None else seed))
    return Simulation(p, copy_state(sim.state), rng)


def rms(x, axis=None):
    return float(np.sqrt(np.mean(np.square(x), axis=axis)))


# ----------------------------------------------------------------------------- part 1
def force_metrics(kr, ref):
    """Error measures of kernel rates ``kr`` against reference rates ``ref`` (docstring above)."""
    dF = np.linalg.norm(kr["dpos"] - ref["dpos"], axis=1)
    S = math.sqrt(np.mean(np.sum(ref["dpos"] ** 2, axis=1)))
    Fk = np.linalg.norm(kr["dpos"], axis=1)
    shape_k = np.concatenate([kr["da"], kr["db"]], axis=1)
    shape_r = np.concatenate([ref["da"], ref["db"]], axis=1)
    return {
        "F_rms": rms(dF) / S, "F_median": float(np.median(dF)) / S, "F_max": float(dF.max()) / S,
        "imbalance": float(np.linalg.norm(kr["dpos"].sum(axis=0)) / Fk.max()),
        "torque": rms(kr["dtheta"] - ref["dtheta"]) / rms(ref["dtheta"]),
        "shape": rms(shape_k - shape_r) / rms(shape_r),
    }


def snapshots_part1(cfg):
    """Dense snapshots: {name: [snapshot dicts]} plus the equilibrated sims (seed 0) for part 2."""
    snaps, sims = {}, {}
    for name in ("fluid", "soft-fluid"):
        eta, v0 = SCENES[name]
        snaps[name] = []
        for seed in range(cfg["p1_seeds"]):
            sim = equilibrated(cfg["p1_N"], eta, v0, seed, cfg["t_eq"][name])
            s = sim.state
            snaps[name].append({"pos": s.pos.copy(), "theta": s.theta.copy(), "a": s.a.copy(),
                                "b": s.b.copy(), "box": s.box.copy()})
            if seed == 0:
                sims[name] = sim
    snaps["synthetic"] = [dense_snapshot(cfg["p1_N"], seed=s, deform=0.15) for s in range(cfg["p1_seeds"])]
    return snaps, sims


def part1_forces(cfg, snaps, log):
    """Force/torque/shape-rate errors per (snapshot class, quadrature, K), pooled over snapshots."""
    out = {}
    for name, group in snaps.items():
        refs = [continuum_rates(s["pos"], s["theta"], s["a"], s["b"], eta=0.0, v0=0.0, box=s["box"])
                for s in group]
        ref = {k: np.concatenate([r[k] for r in refs]) for k in refs[0]}
        Fr = np.linalg.norm(ref["dpos"], axis=1)
        ref_imb = float(np.mean([np.linalg.norm(r["dpos"].sum(0)) / np.linalg.norm(r["dpos"], axis=1).max()
                                 for r in refs]))
        q = shape_indices(np.concatenate([s["a"] for s in group]), np.concatenate([s["b"] for s in group]))
        amp = np.concatenate([np.hypot(s["a"], s["b"]).sum(axis=1) for s in group])
        out[name] = {"cells": len(Fr), "q_mean": float(q.mean()), "amp_mean": float(amp.mean()),
                     "amp_max": float(amp.max()), "ref_imbalance": ref_imb, "rows": []}
        for quad in QUADS:
            for K in cfg["Ks"]:
                krs = [kernel_rates(s["pos"], s["theta"], s["a"], s["b"], eta=0.0, v0=0.0, box=s["box"],
                                    contour_points=K, quadrature=quad) for s in group]
                # imbalance is per snapshot (a sum over one periodic box), then averaged
                imb = float(np.mean([force_metrics(k, r)["imbalance"] for k, r in zip(krs, refs)]))
                kr = {k: np.concatenate([x[k] for x in krs]) for k in krs[0]}
                m = force_metrics(kr, ref)
                m["imbalance"] = imb
                out[name]["rows"].append({"quadrature": quad, "K": K, **m})
        log(f"  part 1 forces: {name} done")
    return out


def part1_cost(cfg, log):
    """Cell-steps/s at N = cfg['cost_N'] for every (quadrature, K), from one warmed state."""
    base = equilibrated(cfg["cost_N"], 0.03, 0.06, 1, cfg["cost_warm"] * 5e-3)
    rates = {}
    for quad in QUADS:  # compile / warm every quadrature once
        fork(base, quadrature=quad).advance(2)
    for rep in range(3):  # interleave repeats so machine load affects all settings alike
        for quad in QUADS:
            for K in cfg["Ks"]:
                sim = fork(base, quadrature=quad, contour_points=K)
                sim.advance(2)
                t0 = time.process_time()
                sim.advance(cfg["cost_steps"])
                r = cfg["cost_N"] * cfg["cost_steps"] / (time.process_time() - t0)
                rates[(quad, K)] = max(rates.get((quad, K), 0.0), r)
    ref = rates[("binary", 40)] if ("binary", 40) in rates else rates[("binary", cfg["Ks"][0])]
    log("  part 1 cost done")
    return [{"quadrature": q, "K": K, "cell_steps_per_s": r, "us_per_cell_step": 1e6 / r,
             "cost_vs_binary40": ref / r} for (q, K), r in rates.items()]


# ----------------------------------------------------------------------------- part 2
def part2_trajectories(cfg, sims, log):
    """Centroid/θ/shape error at time T vs dt (D_r = 0), per scene and quadrature."""
    out = []
    T = cfg["traj_T"]
    for scene, sim in sims.items():
        for quad, K in cfg["traj_settings"]:
            finals = {}
            for dt in list(cfg["traj_dts"]) + [cfg["traj_ref_dt"]]:
                s = fork(sim, Dr=0.0, dt=dt, quadrature=quad, contour_points=K)
                try:
                    s.advance(int(round(T / dt)))
                    finals[dt] = (s.state.unwrapped(), s.state.theta.copy(),
                                  np.concatenate([s.state.a, s.state.b], axis=1), s.state.projections)
                except SimulationError:
                    finals[dt] = None
            r = finals[cfg["traj_ref_dt"]]
            for dt in cfg["traj_dts"]:
                f = finals[dt]
                row = {"scene": scene, "quadrature": quad, "K": K, "dt": dt}
                if f is None or r is None:
                    row.update(pos=np.nan, theta=np.nan, shape=np.nan, projections=-1)
                else:
                    row.update(pos=rms(np.linalg.norm(f[0] - r[0], axis=1)), theta=rms(f[1] - r[1]),
                               shape=rms(f[2] - r[2]), projections=int(f[3]))
                out.append(row)
        log(f"  part 2 trajectories: {scene} done")
    return out


def mean_q_run(sim, T, dt_sample):
    """Advance ``sim`` for time T; ⟨q⟩ over samples in the second half, and projections/cell-step."""
    steps_per = max(1, int(round(dt_sample / sim.params.dt)))
    n = int(round(T / dt_sample))
    qs = []
    for k in range(n):
        sim.advance(steps_per)
        if k >= n // 2:
            qs.append(shape_indices(sim.state.a, sim.state.b).mean())
    return float(np.mean(qs)), sim.state.projections / (sim.params.N * sim.state.step)


def part2_stable(cfg, sims, log):
    """Largest stable dt per scene and quadrature (doubling ladder)."""
    out = []
    for scene, sim in sims.items():
        for quad in cfg["stable_quads"]:
            qref, pref = mean_q_run(fork(sim, dt=cfg["stable_ref_dt"], quadrature=quad, contour_points=40),
                                    cfg["stable_T"], cfg["stable_sample"])
            ladder, largest, largest1, chain1 = [], None, None, True
            for dt in cfg["stable_dts"]:
                try:
                    qm, pr = mean_q_run(fork(sim, dt=dt, quadrature=quad, contour_points=40),
                                        cfg["stable_T"], cfg["stable_sample"])
                    dev = (qm - qref) / qref
                    ok = abs(dev) <= 0.05
                    ladder.append({"dt": dt, "q": qm, "dev": dev, "proj": pr, "status": "ok" if ok else "q>5%"})
                except SimulationError:
                    ok = False
                    ladder.append({"dt": dt, "q": np.nan, "dev": np.nan, "proj": np.nan, "status": "error"})
                if not ok:
                    break
                largest = dt
                chain1 = chain1 and abs(dev) <= 0.01
                if chain1:
                    largest1 = dt
            out.append({"scene": scene, "quadrature": quad, "q_ref": qref, "proj_ref": pref,
                        "largest_dt_5pct": largest, "largest_dt_1pct": largest1, "ladder": ladder})
        log(f"  part 2 stable dt: {scene} done")
    return out


# ----------------------------------------------------------------------------- part 3
def observe(sim, T, t_skip, dt_sample, lag):
    """Run for T; ⟨q⟩, rho_d and MSD(lag) over frames after t_skip; wall time per step."""
    steps_per = int(round(dt_sample / sim.params.dt))
    n = int(round(T / dt_sample))
    k0 = int(round(t_skip / dt_sample))
    pos, unw, qs = [], [], []
    wall = 0.0
    for k in range(n):
        t0 = time.process_time()
        sim.advance(steps_per)
        wall += time.process_time() - t0
        if k >= k0:
            s = sim.state
            pos.append(s.pos.copy())
            unw.append(s.unwrapped())
            qs.append(shape_indices(s.a, s.b).mean())
    msd, _ = msd_curve(np.array(unw))
    rd = defect_statistics(np.array(pos), sim.params.box)["rho_d"]
    return {"q": float(np.mean(qs)), "rho_d": rd, "msd": float(msd[int(round(lag / dt_sample))]),
            "us_per_cell_step": 1e6 * wall / (sim.params.N * n * steps_per)}


def part3_observables(cfg, log):
    out = {"settings": [], "raw": {}}
    eta, v0 = cfg["obs_scene"]
    bases = [equilibrated(cfg["obs_N"], eta, v0, 100 + s, cfg["obs_eq"]) for s in range(cfg["obs_seeds"])]
    for quad, K, dt in cfg["obs_settings"]:
        key = f"{quad} K={K} dt={dt:g}"
        rows = []
        for r, base in enumerate(bases):
            sim = fork(base, seed=1000 + r, quadrature=quad, contour_points=K, dt=dt)
            rows.append(observe(sim, cfg["obs_T"], cfg["obs_skip"], cfg["obs_sample"], cfg["obs_lag"]))
        out["raw"][key] = rows
        out["settings"].append({"key": key, "quadrature": quad, "K": K, "dt": dt})
        log(f"  part 3: {key} done")
    ref_key = out["settings"][0]["key"]
    summary = []
    for st in out["settings"]:
        rows = out["raw"][st["key"]]
        row = dict(st)
        for obs in ("q", "rho_d", "msd"):
            x = np.array([r[obs] for r in rows])
            d = x - np.array([r[obs] for r in out["raw"][ref_key]])
            n = len(x)
            row[obs] = float(x.mean())
            row[obs + "_sem"] = float(x.std(ddof=1) / math.sqrt(n)) if n > 1 else float("nan")
            row[obs + "_delta"] = float(d.mean())
            row[obs + "_delta_sem"] = float(d.std(ddof=1) / math.sqrt(n)) if n > 1 else float("nan")
        row["us_per_cell_step"] = float(np.mean([r["us_per_cell_step"] for r in rows]))
        row["us_per_unit_time"] = row["us_per_cell_step"] / st["dt"]
        summary.append(row)
    out["summary"] = summary
    return out


# ----------------------------------------------------------------------------- reporting
def tables(res, cfg):
    L = []
    w = L.append
    w("# fcsweep speed against error (benchmarks/speed_vs_error.py"
      + (" --quick" if cfg["quick"] else "") + ")")
    w(f"# {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; rho = 0.95, M = 6; "
      "definitions in the script docstring and docs/speed_vs_error.md")
    if "forces" in res:
        cost = {(r["quadrature"], r["K"]): r for r in res.get("cost", [])}
        w("")
        w("## 1. Overlap-rate error vs K against the exact-arc continuum reference (eta = v0 = 0)")
        for name, d in res["forces"].items():
            w("")
            w(f"### {name}: {d['cells']} cells, <q> = {d['q_mean']:.3f}, mean Σ|c_n| = {d['amp_mean']:.3f} "
              f"(max {d['amp_max']:.3f}, bound 0.816); reference imbalance {d['ref_imbalance']:.1e}")
            w(f"{'quad':>7} {'K':>4} {'F rms':>8} {'F med':>8} {'F max':>8} {'|ΣF|/maxF':>10} "
              f"{'torque':>8} {'shape':>8} {'us/cell-step':>13} {'cost/bin40':>10}")
            for r in d["rows"]:
                c = cost.get((r["quadrature"], r["K"]))
                cs = f"{c['us_per_cell_step']:>13.3f} {c['cost_vs_binary40']:>10.2f}" if c else f"{'-':>13} {'-':>10}"
                w(f"{r['quadrature']:>7} {r['K']:>4} {r['F_rms']:>8.3g} {r['F_median']:>8.3g} {r['F_max']:>8.3g} "
                  f"{r['imbalance']:>10.3g} {r['torque']:>8.3g} {r['shape']:>8.3g} {cs}")
    if "cost" in res:
        w("")
        w(f"## 1b. Cost: Simulation at N = {cfg['cost_N']} (eta = 0.03, v0 = 0.06, after {cfg['cost_warm']} "
          f"steps), serial, process CPU time, best of 3 x {cfg['cost_steps']} steps; "
          f"load average at start {res.get('loadavg', '?')}")
        w(f"{'quad':>7} {'K':>4} {'cell-steps/s':>13} {'us/cell-step':>13} {'cost/bin40':>10}")
        for r in sorted(res["cost"], key=lambda r: (QUADS.index(r["quadrature"]), r["K"])):
            w(f"{r['quadrature']:>7} {r['K']:>4} {r['cell_steps_per_s']:>13.3e} {r['us_per_cell_step']:>13.3f} "
              f"{r['cost_vs_binary40']:>10.2f}")
    if "traj" in res:
        w("")
        w(f"## 2. Trajectory error at T = {cfg['traj_T']} vs dt (D_r = 0, N = {cfg['p1_N']}); "
          f"reference dt = {cfg['traj_ref_dt']:g}")
        w("# pos: rms over cells of |r(dt) - r(ref)| in R0; theta: rms rad; shape: rms over modes; "
          "order = log2(err(2dt)/err(dt))")
        w(f"{'scene':>10} {'quad':>7} {'K':>4} {'dt':>8} {'pos':>10} {'order':>6} {'theta':>10} {'shape':>10} {'proj':>6}")
        prev = {}
        for r in res["traj"]:
            k = (r["scene"], r["quadrature"], r["K"])
            order = math.log2(prev[k] / r["pos"]) if k in prev and r["pos"] > 0 and np.isfinite(prev[k]) else float("nan")
            prev[k] = r["pos"]
            w(f"{r['scene']:>10} {r['quadrature']:>7} {r['K']:>4} {r['dt']:>8.5f} {r['pos']:>10.3e} {order:>6.2f} "
              f"{r['theta']:>10.3e} {r['shape']:>10.3e} {r['projections']:>6}")
    if "stable" in res:
        w("")
        w(f"## 2b. Largest stable dt (doubling ladder, D_r = 0.01, K = 40, N = {cfg['p1_N']}, T = {cfg['stable_T']}; "
          f"pass = no SimulationError and |<q> - <q>_ref| <= 5 % of <q>_ref at dt = {cfg['stable_ref_dt']:g})")
        w(f"{'scene':>10} {'quad':>7} {'<q>_ref':>8} {'dt_max(5%)':>10} {'dt_max(1%)':>10}   ladder dt:<q>(dev, projections/cell-step)")
        for r in res["stable"]:
            lad = "  ".join(f"{x['dt']:g}:" + (f"{x['q']:.3f}({100 * x['dev']:+.1f}%,{x['proj']:.2g})"
                                                if x["status"] != "error" else "ERROR") for x in r["ladder"])
            w(f"{r['scene']:>10} {r['quadrature']:>7} {r['q_ref']:>8.4f} {str(r['largest_dt_5pct']):>10} "
              f"{str(r['largest_dt_1pct']):>10}   {lad}")
    if "obs" in res:
        eta, v0 = cfg["obs_scene"]
        w("")
        w(f"## 3. Observables at eta = {eta}, v0 = {v0}, D_r = 0.01, N = {cfg['obs_N']}, {cfg['obs_seeds']} seeds; "
          f"run T = {cfg['obs_T']} from a shared equilibrated state (t = {cfg['obs_eq']}), frames every "
          f"{cfg['obs_sample']} after t = {cfg['obs_skip']}; MSD at lag {cfg['obs_lag']}")
        w("# value = mean ± sem over seeds (the replicate noise); Δ = paired mean difference to the first "
          "(finest) row ± its sem; * marks |Δ| > 2 paired sem (a systematic shift), ! marks |Δ| > 2 sem of the "
          "finest row's value (beyond replicate noise)")
        w(f"{'setting':>26} {'<q>':>16} {'Δ<q>':>19} {'rho_d':>16} {'Δrho_d':>19} {'MSD':>16} {'ΔMSD':>19} "
          f"{'us/cell-step':>12} {'us/(cell·time)':>14}")

        def f(v, e, d=4):
            return f"{v:.{d}f}±{e:.{d}f}"

        ref = res["obs"]["summary"][0]
        for r in res["obs"]["summary"]:
            cells = []
            for obs, d in (("q", 4), ("rho_d", 3), ("msd", 3)):
                star = "*" if abs(r[obs + "_delta"]) > 2 * r[obs + "_delta_sem"] else " "
                star += "!" if abs(r[obs + "_delta"]) > 2 * ref[obs + "_sem"] else " "
                cells.append(f"{f(r[obs], r[obs + '_sem'], d):>16}")
                cells.append(f"{f(r[obs + '_delta'], r[obs + '_delta_sem'], d) + star:>19}")
            w(f"{r['key']:>26} " + " ".join(cells) + f" {r['us_per_cell_step']:>12.2f} {r['us_per_unit_time']:>14.0f}")
    return "\n".join(L) + "\n"


def figure(res, cfg, outdir):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.4))
    ax = axes[0]
    cost = {(r["quadrature"], r["K"]): r["us_per_cell_step"] for r in res.get("cost", [])}
    colors = {"binary": "C3", "linear": "C1", "arc": "C0"}
    styles = {"fluid": "-", "soft-fluid": "--", "synthetic": ":"}
    for name, d in res.get("forces", {}).items():
        for quad in QUADS:
            rows = [r for r in d["rows"] if r["quadrature"] == quad and (quad, r["K"]) in cost]
            if not rows:
                continue
            x = [cost[(quad, r["K"])] for r in rows]
            y = [r["F_rms"] for r in rows]
            ax.loglog(x, y, styles[name], marker="o", ms=3, color=colors[quad],
                      label=f"{quad}, {name}" if True else None)
            if name == "fluid":
                for xi, yi, r in zip(x, y, rows):
                    ax.annotate(f"K={r['K']}", (xi, yi), textcoords="offset points", xytext=(3, 3), fontsize=6,
                                color=colors[quad])
    ax.axhline(0.05, color="grey", lw=0.6, ls="-.")
    ax.set_xlabel(f"µs per cell-step (N = {cfg['cost_N']}, serial)")
    ax.set_ylabel("rms force error / rms force")
    ax.set_title("(a) force error vs cost (K labelled)")
    ax.legend(fontsize=6, ncol=1)
    ax = axes[1]
    for scene, ls in zip(SCENES, ("-", "--", ":")):
        for quad, K in cfg["traj_settings"]:
            rows = [r for r in res.get("traj", []) if r["scene"] == scene and r["quadrature"] == quad
                    and r["K"] == K and np.isfinite(r["pos"])]
            if rows:
                ax.loglog([r["dt"] for r in rows], [r["pos"] for r in rows], ls, marker="os"[K == 40], ms=3,
                          color="C2" if K != 40 else colors[quad], label=f"{quad} K={K}, {scene}")
    dts = np.array(cfg["traj_dts"])
    ax.loglog(dts, 1e-2 * dts / dts[0], color="k", lw=0.6, label="∝ dt")
    ax.loglog(dts, 6e-3 * (dts / dts[0]) ** 2, color="k", lw=0.6, ls="--", label="∝ dt²")
    ax.set_xlabel("dt")
    ax.set_ylabel(f"rms centroid error at T = {cfg['traj_T']} (R0)")
    ax.set_title("(b) trajectory error vs dt (D_r = 0)")
    ax.legend(fontsize=6)
    from matplotlib.ticker import FixedLocator, NullFormatter, NullLocator
    for a, ticks in ((axes[0], [1, 1.5, 2, 3, 4, 6, 8]), (axes[1], list(cfg["traj_dts"]))):
        a.xaxis.set_minor_formatter(NullFormatter())
        a.xaxis.set_minor_locator(NullLocator())
        a.xaxis.set_major_locator(FixedLocator(ticks))
        a.set_xticklabels([f"{t:g}" for t in ticks])
    fig.tight_layout()
    for ext in ("png", "pdf"):
        fig.savefig(outdir / f"work_precision.{ext}", dpi=150)
    plt.close(fig)


def config(quick):
    if quick:
        return {"quick": True, "p1_N": 16, "p1_seeds": 1, "t_eq": {"fluid": 5.0, "soft-fluid": 5.0, "hard": 5.0},
                "Ks": (24, 40), "cost_N": 64, "cost_warm": 100, "cost_steps": 20,
                "traj_T": 0.2, "traj_dts": (0.04, 0.02, 0.01), "traj_ref_dt": 0.005, "traj_settings": (("arc", 40),),
                "stable_T": 0.64, "stable_sample": 0.16, "stable_ref_dt": 0.005, "stable_dts": (0.02, 0.04),
                "stable_quads": ("binary",),
                "obs_N": 16, "obs_seeds": 2, "obs_eq": 2.0, "obs_T": 1.0, "obs_skip": 0.4, "obs_sample": 0.2,
                "obs_lag": 0.4, "obs_scene": (0.03, 0.06),
                "obs_settings": (("arc", 40, 0.01), ("binary", 40, 0.01))}
    return {"quick": False, "p1_N": 64, "p1_seeds": 2,
            "t_eq": {"fluid": 15.0, "soft-fluid": 50.0, "hard": 15.0},
            "Ks": (16, 24, 32, 40, 64, 96, 160), "cost_N": 1024, "cost_warm": 2000, "cost_steps": 60,
            "traj_T": 2.0, "traj_dts": (0.04, 0.02, 0.01, 0.005, 0.0025, 0.00125), "traj_ref_dt": 0.000625,
            "traj_settings": (("arc", 160), ("arc", 40), ("binary", 40)),
            "stable_T": 12.8, "stable_sample": 0.64, "stable_ref_dt": 0.0025,
            "stable_dts": (0.005, 0.01, 0.02, 0.04, 0.08, 0.16, 0.32), "stable_quads": ("binary", "arc"),
            "obs_N": 144, "obs_seeds": 4, "obs_eq": 40.0, "obs_T": 40.0, "obs_skip": 5.0, "obs_sample": 0.2,
            "obs_lag": 10.0, "obs_scene": (0.03, 0.06),
            "obs_settings": (("arc", 80, 0.0025), ("arc", 80, 0.005), ("arc", 40, 0.005), ("arc", 24, 0.005),
                             ("arc", 40, 0.01), ("arc", 40, 0.02), ("linear", 40, 0.005), ("binary", 80, 0.005),
                             ("binary", 40, 0.0025), ("binary", 40, 0.005), ("binary", 40, 0.02))}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="tiny version of every part (< 1 min)")
    ap.add_argument("--outdir", type=pathlib.Path, default=None)
    ap.add_argument("--parts", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--replot", action="store_true",
                    help="rewrite the tables and figure from OUTDIR/speed_vs_error.json without computing")
    args = ap.parse_args(argv)
    cfg = config(args.quick)
    outdir = args.outdir or (pathlib.Path(tempfile.mkdtemp(prefix="fcsweep_sve_")) if args.quick
                             else pathlib.Path(__file__).resolve().parent / "results")
    outdir.mkdir(parents=True, exist_ok=True)
    if args.replot:
        res = json.loads((outdir / "speed_vs_error.json").read_text())
        cfg = res.pop("config")
        text = tables(res, cfg) + f"\n# total runtime {res['runtime_s']:.0f} s\n"
        (outdir / "speed_vs_error.txt").write_text(text)
        figure(res, cfg, outdir)
        print(text)
        return
    numba.set_num_threads(1)  # serial timings: CPU time of this process = kernel time
    t_start = time.perf_counter()

    def log(msg):
        print(f"[{time.perf_counter() - t_start:7.1f} s] {msg}", flush=True)

    res = {"loadavg": " ".join(pathlib.Path("/proc/loadavg").read_text().split()[:3])
           if pathlib.Path("/proc/loadavg").exists() else "?"}
    if 1 in args.parts or 2 in args.parts:
        snaps, sims = snapshots_part1(cfg)
        eta, v0 = SCENES["hard"]
        sims["hard"] = equilibrated(cfg["p1_N"], eta, v0, 0, cfg["t_eq"]["hard"])
        log("snapshots ready")
    if 1 in args.parts:
        res["forces"] = part1_forces(cfg, snaps, log)
        res["cost"] = part1_cost(cfg, log)
    if 2 in args.parts:
        res["traj"] = part2_trajectories(cfg, sims, log)
        res["stable"] = part2_stable(cfg, sims, log)
    if 3 in args.parts:
        res["obs"] = part3_observables(cfg, log)
    res["runtime_s"] = time.perf_counter() - t_start
    text = tables(res, cfg) + f"\n# total runtime {res['runtime_s']:.0f} s\n"
    (outdir / "speed_vs_error.txt").write_text(text)
    safe = json.loads(json.dumps({"config": cfg, **res}, default=lambda o: o.tolist() if hasattr(o, "tolist") else str(o)))
    (outdir / "speed_vs_error.json").write_text(json.dumps(safe, indent=1))
    if 1 in args.parts or 2 in args.parts:
        figure(res, cfg, outdir)
    print(text)
    log(f"wrote {outdir}")


if __name__ == "__main__":
    main()
