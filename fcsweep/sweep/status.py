"""Status of every run of a sweep, from status.json files and run locks."""

from __future__ import annotations

from collections import Counter
from typing import Any

from fcsweep.config import SweepConfig
from fcsweep.io import schema
from fcsweep.io.locks import lock_info, lock_is_stale
from fcsweep.io.status import read_status

__all__ = ["collect_status", "format_status", "summary_line", "STATES"]

#: Displayed states; ``interrupted`` is a ``running`` status whose lock is gone or stale
#: (the next ``fcsweep simulate`` resumes it from its checkpoint).
STATES = ("done", "running", "interrupted", "failed", "pending")


def collect_status(cfg: SweepConfig) -> list[dict[str, Any]]:
    """One dict per run: index, run_id, label, state, steps_done, steps, projections,
    wall_seconds, reason."""
    rows = []
    for spec in cfg.runs():
        run_dir = cfg.run_dir(spec.run_id)
        st = read_status(run_dir) or {}
        state = st.get("status", schema.PENDING)
        lock = lock_info(run_dir / schema.LOCK)
        live_lock = lock is not None and not lock_is_stale(lock)
        if state == schema.DONE and not (run_dir / schema.TRAJECTORY).exists():
            state = "pending"
        if live_lock and state != schema.DONE:
            state = "running"
        elif state == schema.RUNNING:
            state = "interrupted"
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
                "host": (lock or {}).get("host") if live_lock else st.get("host"),
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
        if reasons and r["state"] == "failed" and r["reason"]:
            lines.append(f"{'':6}reason: {r['reason']}")
    lines.append(summary_line(rows))
    return "\n".join(lines)


def _short(n: int) -> str:
    for unit, div in (("G", 1e9), ("M", 1e6), ("k", 1e3)):
        if n >= div:
            return f"{n / div:.3g}{unit}"
    return str(n)
