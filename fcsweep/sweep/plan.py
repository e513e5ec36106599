"""What ``fcsweep simulate`` would do, without doing it (``--dry-run``).

:func:`plan_runs` reads the status, checkpoint and lock of every selected run and says,
for each, whether the next ``simulate`` starts it, resumes it (from which step), extends
it (done, but wanted longer), skips it, or cannot touch it (held by another process,
failed earlier, or computed with other run settings), with the steps left.  The decision
is :func:`fcsweep.sweep.lifecycle.assess`, the one the runner acts on.  It reads files
only; nothing is written.  :func:`print_plan` prints the dry run's table, totals and
advice (the command line gives it its echo).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from fcsweep.config import RunSpec, SweepConfig
from fcsweep.sweep.bench import STARTUP_CPU_S, cpu_share, estimate_costs, wall_time
from fcsweep.sweep.lifecycle import ACTIONS, assess
from fcsweep.sweep.options import SweepOptions
from fcsweep.sweep.progress import format_duration

__all__ = ["PlannedRun", "plan_runs", "print_plan", "plan_advice", "ACTIONS"]


@dataclass(frozen=True)
class PlannedRun:
    """One run's fate under the next ``simulate``: ``action``, the step it starts from
    and the steps it would compute, a note for people, and the run's ``state`` (the
    word ``fcsweep status`` shows)."""

    spec: RunSpec
    action: str
    from_step: int
    steps_left: int
    note: str = ""
    state: str = ""


def _plan_one(cfg: SweepConfig, spec: RunSpec, force: bool, retry_failed: bool, stale_after: float) -> PlannedRun:
    a = assess(cfg, spec, force=force, retry_failed=retry_failed, stale_after=stale_after)
    note = a.reason
    if a.action == "failed":
        note = f"{a.reason}; --retry-failed reruns it"
    elif a.action == "start" and a.damaged is not None:
        note = f"{a.reason}; recomputed"
    return PlannedRun(spec, a.action, a.from_step, a.steps_left, note, a.state)


def plan_runs(cfg: SweepConfig, specs, options: SweepOptions | None = None) -> list[PlannedRun]:
    """The action of the next ``fcsweep simulate`` for each of ``specs`` (same order).

    Parameters
    ----------
    cfg : SweepConfig
    specs : sequence of RunSpec
        The selected runs (:func:`fcsweep.sweep.executors.select_runs`).
    options : SweepOptions, optional
        The ``simulate`` options (``force``, ``retry_failed``, ``stale_after`` matter here).
    """
    o = options or SweepOptions()
    return [_plan_one(cfg, s, o.force, o.retry_failed, o.stale_after) for s in specs]


def print_plan(cfg: SweepConfig, specs, options: SweepOptions, *, source: str, out_dir, processes: int,
               advice_arg: str, echo: Callable[[str], None], log: Callable[[str], None] | None = None) -> None:
    """Print what ``simulate`` would do and what it would cost (``--dry-run``; writes nothing).

    Parameters
    ----------
    cfg : SweepConfig
    specs : sequence of RunSpec
    options : SweepOptions
    source : str
        How the config is named in the first line.
    out_dir : path-like
        The resolved output directory.
    processes : int
        Processes the wall-time estimate assumes.
    advice_arg : str
        How the user named the sweep (``configs/x.yaml -o out``), for advice lines.
    echo : callable
        Receives each line of the report (stdout).
    log : callable, optional
        Receives what the cost estimate says while it measures (stderr).
    """
    plans = plan_runs(cfg, specs, options)
    echo(f"dry run: {len(specs)} run(s) of {source} -> {out_dir} (nothing is written)")
    work = [p for p in plans if p.steps_left > 0]
    costs, src = estimate_costs(cfg, work, log=log) if work else ([], "")
    cost = {p.spec.index: c for p, c in zip(work, costs)}
    echo(f"{'idx':>4}  {'run_id':12}  {'action':8}  {'from step':>9}  {'steps':>9}  {'est. wall':>9}  parameters")
    for p in plans:
        est = format_duration(cost[p.spec.index][1]) if p.spec.index in cost else ""
        echo(f"{p.spec.index:>4}  {p.spec.run_id:12}  {p.action:8}  {p.from_step:>9}  {p.steps_left:>9}  "
             f"{est:>9}  {p.spec.label()}" + (f"  ({p.note})" if p.note else ""))
    n = {a: sum(p.action == a for p in plans) for a in ACTIONS}
    echo(", ".join(f"{n[a]} to {a}" if a in ("start", "resume", "extend", "skip") else f"{n[a]} {a}"
                   for a in ACTIONS if n[a] or a in ("start", "resume", "skip")))
    if work:
        cpu = STARTUP_CPU_S + sum(c for c, _ in costs)
        wall = STARTUP_CPU_S + wall_time([w for _, w in costs], processes)
        echo(f"estimated {format_duration(cpu)} of CPU and about {format_duration(wall)} of wall time on "
             f"{processes} process(es) with a free core each, start-up included [{src}]")
        share = cpu_share()
        if share < 0.9:
            echo(f"note: other jobs share this machine now (this process gets {share:.0%} of a core): "
                 f"at this load the wall time would be about {format_duration(wall / share)}")
    for line in plan_advice(n, advice_arg):
        echo(line)


def plan_advice(n: dict, arg: str) -> list[str]:
    """What to do about blocked, failed and locked runs (``n``: action -> count)."""
    cmd = f"fcsweep simulate {arg}".rstrip()
    out = []
    if n["blocked"]:
        out.append(f"{n['blocked']} run(s) hold results of other run settings: `{cmd} --force` recomputes them, "
                   "or give another output directory (-o)")
    if n["failed"]:
        out.append(f"{n['failed']} run(s) failed earlier and are not rerun: `{cmd} --retry-failed`")
    if n["locked"]:
        out.append(f"{n['locked']} run(s) are being computed by another process")
    return out
