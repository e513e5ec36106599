"""The rounds of ``fcsweep refine``: simulate, analyse and aggregate, add points, again.

Each round computes every run not done yet (:func:`fcsweep.sweep.launch.compute`),
analyses and aggregates the sweep, reads the point labels of ``phase_diagram.nc`` and
records the points :func:`fcsweep.sweep.refine.propose_points` proposes in
``<output>/refinement.json``.  The sweep layer sits below the analysis, so the analysis
step and the label names come in as arguments: the command line passes
:func:`fcsweep.results.analyze.analyze_sweep` followed by
:func:`fcsweep.results.aggregate.aggregate_sweep`, and the flag names of
:mod:`fcsweep.analysis.phase`.
"""

from __future__ import annotations

import datetime as _dt
from pathlib import Path
from typing import Callable, Mapping

from fcsweep.config import ConfigError, SweepConfig
from fcsweep.sweep.options import SweepOptions

__all__ = ["refine_loop"]


class _Exit(Exception):
    """Leave the loop with an exit code (its message already said)."""

    def __init__(self, code: int):
        super().__init__(code)
        self.code = code


def refine_loop(cfg: SweepConfig, *, analyse: Callable[[SweepConfig], Path],
                flag_names: Mapping[str, Mapping[int, str]], say: Callable[[str], None],
                echo: Callable[[str], None], options: SweepOptions | None = None, rounds: int = 1,
                max_points: int | None = None, add_only: bool = False, quiet: bool = False,
                config: str | None = None) -> int:
    """Run ``fcsweep refine``; returns its exit code.

    Parameters
    ----------
    cfg : SweepConfig
    analyse : callable
        ``analyse(cfg)`` analyses every finished run, aggregates the sweep and returns
        the path of ``phase_diagram.nc``.
    flag_names : mapping
        Label (``phase``, ``percolated``) -> code -> name, for the reasons printed.
    say : callable
        Receives progress and error lines (meant for stderr).
    echo : callable
        Receives the added points, one line each (meant for stdout).
    options : SweepOptions, optional
        How runs are computed (:class:`fcsweep.sweep.options.SweepOptions`; default serial).
    rounds : int
        Refinement rounds after the sweep is complete.
    max_points : int, optional
        Most points added per round.
    add_only : bool
        Compute nothing: analyse, aggregate and add one round of points (job arrays).
    quiet : bool
        No progress display.
    config : str, optional
        The config as given on the command line, for the job array hint.

    Returns
    -------
    int
        0; 1 if a run of the last computing round failed; 2 if the refinement file does
        not fit the config or the runs do not fit on disk; 128 + signal number if stopped.
    """
    options = options or SweepOptions()
    try:
        failed = 0
        for k in range(1 if add_only else rounds + 1):
            if not add_only:
                failed = _compute(cfg, options, quiet, say)
            path = analyse(cfg)
            say(f"fcsweep: aggregated -> {path}")
            if k == rounds:
                break
            before = len(_runs(cfg, say))
            if not _add(cfg, path, max_points, flag_names, say, echo):
                break
            cfg = _checked(cfg.with_refinement, say)  # the runs now include the points just recorded
            if add_only:
                last = len(_runs(cfg, say)) - 1
                say(f"fcsweep: new runs {before}..{last}, e.g. sbatch --array={before}-{last} "
                    f"workflows/slurm_array.sh {config}")
    except _Exit as stop:
        return stop.code
    return 1 if failed else 0


def _checked(call, say):
    """``call()``; exit 2 with the message when the refinement file does not fit the config."""
    try:
        return call()
    except ConfigError as exc:
        say(f"fcsweep: invalid config: {exc}")
        raise _Exit(2) from None


def _runs(cfg: SweepConfig, say) -> list:
    """The runs of a sweep, refined points included."""
    return _checked(cfg.runs, say)


def _compute(cfg: SweepConfig, options: SweepOptions, quiet: bool, say) -> int:
    """Simulate every run not done yet; returns the number that failed."""
    from fcsweep.sweep.launch import compute, space_code, stop_code
    from fcsweep.sweep.progress import Progress

    specs = _runs(cfg, say)
    code = space_code(cfg, specs, say)
    if code:
        raise _Exit(code)
    progress = Progress(len(specs), enabled=not quiet)
    outcomes = compute(cfg, specs, options, progress=progress, say=say)
    code = stop_code(outcomes, say)
    if code is not None:
        raise _Exit(code)
    failed = sum(o.outcome == "failed" for o in outcomes)
    say(f"fcsweep: {len(specs)} runs ({sum(o.outcome == 'done' for o in outcomes)} computed now, "
        f"{failed} failed)")
    return failed


def _add(cfg: SweepConfig, dataset: Path, max_points: int | None, flag_names, say, echo) -> int:
    """Propose and record one round of points; returns how many."""
    import xarray as xr

    from fcsweep.io.refinement import append_round
    from fcsweep.sweep.refine import point_labels, propose_points

    with xr.open_dataset(dataset) as ds:
        labels = point_labels(ds, _runs(cfg, say), cfg.swept)
    new = propose_points(labels, cfg.swept, log_axes=cfg.log_axes, max_points=max_points, flag_names=flag_names)
    if not new:
        say("fcsweep: no neighbours with differing or undetermined labels: nothing to refine")
        return 0
    number = append_round(cfg.output, [p.point for p in new], [p.why for p in new],
                          _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"))
    say(f"fcsweep: refinement round {number}: {len(new)} point(s) added")
    for p in new:
        echo(f"  {' '.join(f'{a}={v}' for a, v in p.point.items())}: {p.why}")
    return len(new)
