"""Status of every run of a sweep, from status.json files, run locks and analysis files.

Besides the run state, each row says whether the run is analysed (``analysis``:
``yes``, ``stale`` -- the trajectory is newer than its analysis.h5 or the analysis used
another transient than the config --, ``no``, or empty while the run is not done) and,
for done runs, whether they were computed with other run settings than the config now
has (``outdated``: e.g. ``steps 2000 -> 4000``).
"""

from __future__ import annotations

from collections import Counter
from pathlib import Path
from typing import Any

from fcsweep.config import SweepConfig
from fcsweep.config.settings import settings_for_run
from fcsweep.io import schema
from fcsweep.io.rundir import RunDirectory, analysis_is_current
from fcsweep.io.sweepdir import run_state
from fcsweep.sweep.length import extension_of, frames_done
from fcsweep.sweep.lifecycle import fingerprint_of, settings_change

__all__ = ["collect_status", "format_status", "summary_line", "cost_line", "cost_totals", "analysis_state",
           "settings_change", "advice", "left_line", "STATES", "LEGEND"]

#: The states of :data:`fcsweep.io.schema.STATUSES` (:func:`fcsweep.io.sweepdir.run_state`)
#: in display order: finished, in flight, stopped, not started.  ``interrupted`` is a run
#: stopped by a signal or a ``running`` status whose lock is gone or stale (the next
#: ``fcsweep simulate`` resumes it from its checkpoint); ``corrupt`` a done run whose
#: trajectory failed verification (the next ``fcsweep simulate`` recomputes it).
STATES = tuple(sorted(schema.STATUSES, key=(schema.DONE, schema.RUNNING, schema.INTERRUPTED, schema.FAILED,
                                            schema.CORRUPT, schema.PENDING).index))

#: What the less obvious columns of :func:`format_status` mean (printed under the table).
LEGEND = ("projected: % of the run's cell-steps whose shape left the admissible set and was scaled back "
          "(docs/model.md; above 25 % the run warns that dt is too large); stop: why a done run stopped "
          "(steps: at run.steps; settled: run.until) or 'extend'")


def collect_status(cfg: SweepConfig, analysis_settings: dict | None = None, *,
                   verify: bool = False) -> list[dict[str, Any]]:
    """One dict per run: index, run_id, label, state, steps_done, steps, projections,
    projected (projections per cell-step done, or ``None``), wall_seconds, reason, host,
    analysis, outdated, stop_reason, extend (why a done run will be extended by the next
    ``simulate``, else ``None``), check (the last ``run.until`` verdict), the cost keys of
    :data:`fcsweep.io.schema.COST_KEYS`, and cpu_left / cost_source: the estimated CPU
    seconds the run still needs (:mod:`fcsweep.sweep.cost`, from this machine's cached
    measurement, else the documented fallback; 0 for done and failed runs; with
    ``run.until`` to the cap) and where its cost per cell-step comes from.

    ``analysis_settings``: the settings ``fcsweep analyze`` would use now (the caller
    knows them; this layer does not import the analysis); an analysis.h5 made with
    others is ``stale``.  Without them only the transient is compared. With ``verify``,
    every done run's trajectory is read in full (all checksums) and a damaged one is
    marked ``corrupt`` in its status file (unless a live process holds it)."""
    rows = []
    for spec in cfg.runs():
        rd = RunDirectory(cfg.run_dir(spec.run_id), spec.run_id, spec.index, spec.params)
        rs = run_state(rd.path)  # the state analyze, aggregate and simulate's life cycle name too
        if verify and rs.state == schema.DONE:
            problem = rd.verify(frames_done(cfg.run, rs.st))
            if problem is not None:
                rd.mark_corrupt(problem)
                rs = run_state(rd.path)
        state, st, lock = rs.state, rs.st, rs.lock
        extend = extension_of(cfg.run, st) if state == schema.DONE else None
        rows.append(
            {
                "index": spec.index,
                "run_id": spec.run_id,
                "label": spec.label(),
                "state": state,
                "steps_done": int(st.get("steps_done", 0)),
                "steps": cfg.run.steps if extend else int(st.get("steps", cfg.run.steps)),
                "projections": st.get("projections"),
                "projected": (int(st["projections"]) / (int(spec.params["N"]) * int(st["steps_done"]))
                              if st.get("projections") is not None and int(st.get("steps_done") or 0) > 0
                              else None),
                "wall_seconds": st.get("wall_seconds"),
                "reason": rs.reason if state == schema.CORRUPT else st.get("reason", ""),
                "host": lock.get("host") if lock else st.get("host"),
                "analysis": (analysis_state(rd.path, cfg.run.transient,
                                            settings_for_run(analysis_settings, int(spec.params["N"])))
                             if state == schema.DONE else ""),
                "outdated": (settings_change(st.get("fingerprint"), fingerprint_of(cfg, spec))
                             if state == schema.DONE else ""),
                "stop_reason": st.get("stop_reason"),
                "extend": extend,
                "check": st.get("check"),
                **{k: st.get(k) for k in schema.COST_KEYS},
            }
        )
    _add_time_left(cfg, rows)
    return rows


def _add_time_left(cfg: SweepConfig, rows: list[dict[str, Any]]) -> None:
    """Fill ``cpu_left`` and ``cost_source`` of every row (cached costs only: never times)."""
    from fcsweep.sweep.bench import CHECKPOINT_CPU_S, COST_KEYS, RUN_CPU_S, setting_groups
    from fcsweep.sweep.cost import cell_step_seconds, setting_points

    specs = {s.index: s for s in cfg.runs()}
    groups = setting_groups(cfg, list(specs.values()))
    costs = {}
    for r in rows:
        spec = specs[r["index"]]
        todo = r["state"] not in (schema.DONE, schema.FAILED) or bool(r.get("extend"))
        start = 0 if r["state"] == schema.CORRUPT else r["steps_done"]
        left = max(cfg.run.steps - start, 0) if todo else 0
        r["cpu_left"], r["cost_source"] = 0.0, None
        if not left:
            continue
        key = tuple(spec.params[k] for k in COST_KEYS)
        if key not in costs:
            costs[key] = cell_step_seconds(setting_points(groups[key]), measure=False)
        c = costs[key]
        checkpoints = -(-left // cfg.run.checkpoint_every)
        r["cpu_left"] = RUN_CPU_S + CHECKPOINT_CPU_S * checkpoints + int(spec.params["N"]) * left * c.seconds
        r["cost_source"] = c.describe()


def left_line(rows: list[dict[str, Any]]) -> str:
    """E.g. ``left: about 8.2 h of CPU for 36 run(s) (one core each; 0.85 us per cell-step
    (measured earlier on this machine))``, or ``""`` when nothing is left."""
    from fcsweep.sweep.progress import format_duration

    todo = [r for r in rows if r.get("cpu_left")]
    if not todo:
        return ""
    sources = sorted({r["cost_source"] for r in todo if r.get("cost_source")})
    hint = "" if all("measured" in s for s in sources) else "; `fcsweep bench` measures it here"
    return (f"left: about {format_duration(sum(r['cpu_left'] for r in todo))} of CPU for {len(todo)} run(s) "
            f"(to run.steps; {', '.join(sources)}{hint})")


def analysis_state(run_dir, transient: float, settings: dict | None = None) -> str:
    """``yes``, ``stale`` or ``no``: is the run's ``analysis.h5`` there and up to date
    (:func:`fcsweep.io.rundir.analysis_is_current` against the run's trajectory, with
    ``settings`` if given, else the config's ``transient``)?"""
    run_dir = Path(run_dir)
    path = run_dir / schema.ANALYSIS
    if not path.exists():
        return "no"
    current = analysis_is_current(path, run_dir / schema.TRAJECTORY, settings=settings, transient=transient)
    return "yes" if current else "stale"


def summary_line(rows: list[dict[str, Any]]) -> str:
    """E.g. ``4 runs: 2 done, 1 running, 0 interrupted, 1 failed, 0 pending`` (plus how
    many done runs the next ``simulate`` extends, and how many stopped as settled)."""
    c = Counter(r["state"] for r in rows)
    line = f"{len(rows)} runs: " + ", ".join(f"{c.get(s, 0)} {s}" for s in STATES)
    ext = sum(bool(r.get("extend")) for r in rows)
    settled = sum(r.get("stop_reason") == "settled" and r["state"] == schema.DONE for r in rows)
    if settled:
        line += f"; {settled} stopped as settled (run.until)"
    if ext:
        line += f"; {ext} done run(s) will be extended by the next simulate"
    return line


def cost_totals(rows: list[dict[str, Any]]) -> dict[str, float]:
    """Sums of the cost keys over runs (missing values count 0)."""
    return {k: float(sum(float(r.get(k) or 0.0) for r in rows)) for k in schema.COST_KEYS}


def cost_line(rows: list[dict[str, Any]]) -> str:
    """E.g. ``cost: 3.2e+09 cell-steps in trajectories (3.3e+09 integrated), 12.5 CPU-hours
    (0.4 in until checks), 6.3 h wall summed over runs``."""
    t = cost_totals(rows)
    return (f"cost: {t['cell_steps']:.3g} cell-steps in trajectories ({t['cell_steps_computed']:.3g} integrated), "
            f"{t['cpu_seconds'] / 3600:.3g} CPU-hours ({t['check_cpu_seconds'] / 3600:.3g} in until checks), "
            f"{t['wall_seconds'] / 3600:.3g} h wall summed over runs")


def format_status(rows: list[dict[str, Any]], *, reasons: bool = True) -> str:
    """Fixed-width table with a progress column and a summary line."""
    head = (f"{'idx':>4}  {'run_id':12}  {'state':11}  {'progress':>14}  {'stop':8}  {'projected':>9}  "
            f"{'wall[s]':>8}  {'cpu[s]':>8}  {'analysed':8}  parameters")
    lines = [head, "-" * len(head)]
    for r in rows:
        pct = 100.0 * r["steps_done"] / max(r["steps"], 1)
        prog = f"{pct:5.1f}% {_short(r['steps_done'])}"
        proj = "" if r.get("projected") is None else f"{100 * r['projected']:.2f}%"
        wall = "" if r["wall_seconds"] is None else f"{float(r['wall_seconds']):.1f}"
        cpu = "" if r.get("cpu_seconds") is None else f"{float(r['cpu_seconds']):.1f}"
        stop = "extend" if r.get("extend") else (r.get("stop_reason") or "") if r["state"] == "done" else ""
        lines.append(
            f"{r['index']:>4}  {r['run_id']:12}  {r['state']:11}  {prog:>14}  {stop:8}  {proj:>9}  {wall:>8}  "
            f"{cpu:>8}  {r.get('analysis', ''):8}  {r['label']}"
        )
        if reasons and r["state"] in ("failed", "corrupt", "interrupted") and r["reason"]:
            lines.append(f"{'':6}reason: {r['reason']}")
        if r.get("outdated"):
            lines.append(f"{'':6}computed with other run settings ({r['outdated']})")
        if reasons and r.get("extend"):
            lines.append(f"{'':6}will be extended: {r['extend']}")
        check = r.get("check") or {}
        if reasons and r["state"] in ("running", "interrupted") and check.get("unmet"):
            lines.append(f"{'':6}not settled at step {check.get('step')}: {'; '.join(check['unmet'])}")
    lines.append(LEGEND)
    lines.append(cost_line(rows))
    left = left_line(rows)
    if left:
        lines.append(left)
    lines.append(summary_line(rows))
    return "\n".join(lines)


def advice(rows: list[dict[str, Any]], config_arg: str = "") -> list[str]:
    """What to do next, one line per situation found in ``rows``."""
    out = []
    c = Counter(r["state"] for r in rows)
    cmd = f"fcsweep simulate {config_arg}".rstrip()
    old = [r for r in rows if r.get("outdated")]
    if old:
        out.append(f"{len(old)} done run(s) were computed with other run settings ({old[0]['outdated']}): "
                   f"`{cmd} --force` recomputes them, or give another output directory (-o)")
    if c.get("failed"):
        out.append(f"{c['failed']} run(s) failed: fix the cause (see reason) and run `{cmd} --retry-failed`")
    if c.get("pending") or c.get("interrupted"):
        out.append(f"`{cmd}` computes the pending runs and resumes interrupted ones from their checkpoints")
    acmd = f"fcsweep analyze {config_arg}".rstrip()
    missing = sum(r.get("analysis") == "no" for r in rows)
    stale = sum(r.get("analysis") == "stale" for r in rows)
    if missing:
        out.append(f"{missing} done run(s) not analysed: `{acmd}`")
    if stale:
        out.append(f"{stale} run(s) with a stale analysis: `{acmd} --force` recomputes them")
    return out


def _short(n: int) -> str:
    for unit, div in (("G", 1e9), ("M", 1e6), ("k", 1e3)):
        if n >= div:
            return f"{n / div:.3g}{unit}"
    return str(n)
