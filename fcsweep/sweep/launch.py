"""Launching runs from a command: the stop handler around the executors, the report, the
exit code.

``fcsweep simulate`` and each round of ``fcsweep refine`` compute runs the same way:
:func:`compute` installs the graceful stop handler (:mod:`fcsweep.sweep.interrupt`) for
the time of :func:`fcsweep.sweep.executors.run_sweep` and closes the progress display;
:func:`stop_code` then says how the sweep was stopped, if it was, and gives the exit
code ``128 + signal number``.  :func:`simulate_runs` is the whole of ``fcsweep simulate``
after option parsing: compute, summary, failures and advice, and the exit code (0 all
finished; 1 a run failed or was left unfinished; 2 Dask scheduler unreachable; 128 +
signal number when stopped).

Messages go to ``say`` (the command line passes an echo to stderr) as whole lines,
``fcsweep:`` prefix included; nothing here imports click or the command line.
"""

from __future__ import annotations

from typing import Callable, Sequence

from fcsweep.config import RunSpec, SweepConfig
from fcsweep.sweep import interrupt
from fcsweep.sweep.executors import run_sweep, unfinished
from fcsweep.sweep.options import SweepOptions
from fcsweep.sweep.progress import Progress
from fcsweep.sweep.runner import RunOutcome

__all__ = ["compute", "stop_code", "space_code", "simulate_runs", "failure_advice"]

#: Part of the runner's message for a run directory written with other run settings.
CONFLICT = "computed with other run settings"


def compute(cfg: SweepConfig, specs: Sequence[RunSpec], options: SweepOptions, *, progress: Progress,
            say: Callable[[str], None]) -> list[RunOutcome] | None:
    """:func:`fcsweep.sweep.executors.run_sweep` with the stop handler installed; the
    progress display is closed afterwards.

    Parameters
    ----------
    cfg : SweepConfig
    specs : sequence of RunSpec
    options : SweepOptions
        How to compute them (:class:`fcsweep.sweep.options.SweepOptions`).
    progress : Progress
    say : callable
        Receives the message when the Dask scheduler cannot be reached.

    Returns
    -------
    list of RunOutcome, or None
        ``None`` if ``executor`` is ``dask`` and its scheduler cannot be reached (said).
    """
    previous = interrupt.install()
    try:
        return run_sweep(cfg, specs, options, progress=progress)
    except (OSError, TimeoutError) as exc:
        if options.executor != "dask":
            raise
        say(f"fcsweep: cannot reach the Dask scheduler at {options.scheduler}: {exc}")
        return None
    finally:
        progress.close()
        interrupt.restore(previous)


def stop_code(outcomes: Sequence[RunOutcome], say: Callable[[str], None], resume: str | None = None) -> int | None:
    """If a stop signal was received: say so and return ``128 + signal number``, else ``None``.

    Parameters
    ----------
    outcomes : sequence of RunOutcome
        The runs of the stopped sweep (counted in the message when ``resume`` is given).
    say : callable
    resume : str, optional
        The command that resumes (``fcsweep simulate ...``); without it the message asks
        for the same command again.
    """
    sig = interrupt.requested()
    if sig is None:
        return None
    if resume is None:
        say(f"fcsweep: stopped by {interrupt.reason()}; run the same command again to go on")
    else:
        say(f"fcsweep: stopped by {interrupt.reason()} ({interrupt.interrupted_phrase(outcomes) or 'no run'}"
            f"); resume with: {resume}")
    return interrupt.exit_code(sig)


def space_code(cfg: SweepConfig, specs: Sequence[RunSpec], say: Callable[[str], None], what: str = "") -> int:
    """:func:`fcsweep.sweep.space.check_space`: 2 (said, prefixed by ``what``) if the output
    directory cannot be created or the largest trajectory still to write does not fit,
    else 0 (with a warning said if all of them together may not fit)."""
    from fcsweep.sweep.space import check_space

    try:
        note = check_space(cfg, specs)
    except OSError as exc:
        say(f"fcsweep: {what}{exc.strerror or exc}")
        return 2
    if note:
        say(f"fcsweep: warning: {note}")
    return 0


def simulate_runs(cfg: SweepConfig, specs: Sequence[RunSpec], options: SweepOptions, *, progress: Progress,
                  say: Callable[[str], None], resume: str, advice_arg: str = "") -> int:
    """Compute ``specs`` and report as ``fcsweep simulate`` does; returns the exit code.

    Parameters
    ----------
    cfg : SweepConfig
    specs : sequence of RunSpec
    options : SweepOptions
        How to compute them (:class:`fcsweep.sweep.options.SweepOptions`).
    progress : Progress
    say : callable
        Receives every line of the report (meant for stderr).
    resume : str
        The command that resumes the sweep after a stop signal.
    advice_arg : str
        How the user named the sweep (``configs/x.yaml -o out``), for advice lines.

    Returns
    -------
    int
        0 every run finished; 1 some run failed or was left unfinished by a dead lock
        holder; 2 the Dask scheduler cannot be reached; 128 + signal number if stopped.
    """
    outcomes = compute(cfg, specs, options, progress=progress, say=say)
    if outcomes is None:
        return 2
    counts = {k: sum(o.outcome == k for o in outcomes) for k in ("done", "skipped", "locked", "failed",
                                                                   "interrupted")}
    say(f"fcsweep: {counts['done']} computed, {counts['skipped']} already done, "
        f"{counts['locked']} held by other processes, {counts['failed']} failed"
        + (f", {interrupt.interrupted_phrase(outcomes)}" if counts["interrupted"] else ""))
    for o in outcomes:
        if o.outcome == "failed":
            say(f"  failed: run {o.index} {o.run_id}: {o.message}")
    code = stop_code(outcomes, say, resume)
    if code is not None:
        return code
    lost = unfinished(cfg, outcomes, options.stale_after)
    for o in lost:
        say(f"  unfinished: run {o.index} {o.run_id}: its lock holder stopped without finishing "
            f"({o.message}); the next launch computes it")
    if counts["failed"]:
        for line in failure_advice(outcomes, advice_arg):
            say(f"fcsweep: {line}")
    return 1 if counts["failed"] or lost else 0


def failure_advice(outcomes: Sequence[RunOutcome], arg: str) -> list[str]:
    """Advice that fits the failures: other settings (--force / -o) or errors (--retry-failed)."""
    cmd = f"fcsweep simulate {arg}".rstrip()
    failed = [o for o in outcomes if o.outcome == "failed"]
    conflicts = [o for o in failed if CONFLICT in o.message]
    out = []
    if conflicts:
        out.append(f"{len(conflicts)} run(s) were computed with other run settings than the config has now: "
                   f"`{cmd} --force` recomputes them, or give another output directory (-o)")
    if len(conflicts) < len(failed):
        out.append(f"{len(failed) - len(conflicts)} run(s) failed: fix the cause and rerun with "
                   f"`{cmd} --retry-failed`")
    return out
