"""Status of every run of a sweep, from status.json files and run locks."""

from __future__ import annotations

from collections import Counter
from typing import Any

from fcsweep.config import SweepConfig
from fcsweep.io import schema
from fcsweep.io.rundir import RunDirectory

__all__ = ["collect_status", "format_status", "summary_line", "STATES"]

#: Displayed states; ``interrupted`` is a run stopped by a signal or a ``running`` status
#: whose lock is gone or stale (the next ``fcsweep simulate`` resumes it from its
#: checkpoint); ``corrupt`` a done run whose trajectory failed verification (the next
#: ``fcsweep simulate`` recomputes it).
STATES = ("done", "running", "interrupted", "failed", "corrupt", "pending")


def collect_status(cfg: SweepConfig, *, verify: bool = False) -> list[dict[str, Any]]:
    """One dict per run: index, run_id, label, state, steps_done, steps, projections,
    wall_seconds, reason, host.

    With ``verify``, every done run's trajectory is read in full (all checksums) and a
    damaged one is marked ``corrupt`` in its status file (unless a live process holds it).
    """
    rows = []
    for spec in cfg.runs():
        rd = RunDirectory(cfg.run_dir(spec.run_id), spec.run_id, spec.index, spec.params)
        state = rd.state()
        if verify and state == schema.DONE:
            problem = rd.verify(cfg.run.n_frames)
            if problem is not None:
                rd.mark_corrupt(problem)
                state = schema.CORRUPT
        st = rd.status()
        lock = rd.live_lock()
        rows.append(
            {
                "index": spec.index,
                "run_id": spec.run_id,
                "label": spec.label(),
                "state": state,
                "steps_done": int(st.get("steps_done", 0)),
                "steps": int(st.get("steps", cfg.run.steps)),
                "projections": st.get("projections"),
                "wall_seconds": st.get("wall_seconds"),
                "reason": st.get("reason", ""),
                "host": lock.get("host") if lock else st.get("host"),
            }
        )
    return rows


def summary_line(rows: list[dict[str, Any]]) -> str:
    """E.g. ``4 runs: 2 done, 1 running, 0 interrupted, 1 failed, 0 pending``."""
    c = Counter(r["state"] for r in rows)
    return f"{len(rows)} runs: " + ", ".join(f"{c.get(s, 0)} {s}" for s in STATES)


def format_status(rows: list[dict[str, Any]], *, reasons: bool = True) -> str:
    """Fixed-width table with a progress column and a summary line."""
    head = f"{'idx':>4}  {'run_id':12}  {'state':11}  {'progress':>14}  {'proj':>6}  {'wall[s]':>8}  parameters"
    lines = [head, "-" * len(head)]
    for r in rows:
        pct = 100.0 * r["steps_done"] / max(r["steps"], 1)
        prog = f"{pct:5.1f}% {_short(r['steps_done'])}"
        proj = "" if r["projections"] is None else str(r["projections"])
        wall = "" if r["wall_seconds"] is None else f"{float(r['wall_seconds']):.1f}"
        lines.append(
            f"{r['index']:>4}  {r['run_id']:12}  {r['state']:11}  {prog:>14}  {proj:>6}  {wall:>8}  {r['label']}"
        )
        if reasons and r["state"] in ("failed", "corrupt", "interrupted") and r["reason"]:
            lines.append(f"{'':6}reason: {r['reason']}")
    lines.append(summary_line(rows))
    return "\n".join(lines)


def _short(n: int) -> str:
    for unit, div in (("G", 1e9), ("M", 1e6), ("k", 1e3)):
        if n >= div:
            return f"{n / div:.3g}{unit}"
    return str(n)
