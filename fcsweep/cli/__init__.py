"""Command line, in the order of the work: ``fcsweep validate | bench | simulate | status |
analyze | aggregate | plot | movie | export | refine``, ``measure`` for segmented images of
real cells, and the helpers ``list-runs``, ``schema`` and ``compile``.

Modules: :mod:`fcsweep.cli.main` (the group, its command order, the entry point),
:mod:`fcsweep.cli.run` (validate, schema, bench, simulate, list-runs, compile),
:mod:`fcsweep.cli.results` (status, analyze, aggregate, plot, movie, export, refine),
:mod:`fcsweep.cli.measure` and :mod:`fcsweep.cli.common` (options and exits they share).

Every command takes an optional CONFIG (a sweep YAML file); without one it uses the
built-in demo sweep (``fcsweep/data/smoke.yaml``, identical to ``configs/smoke.yaml``),
which writes to ``./fcsweep-demo``.  Every command that reads or writes a sweep prints
the output directory it resolved.

Exit codes: 0 success; 1 some run failed or was left unfinished (the others completed),
or a results command (status, analyze, aggregate, plot, movie, export) found nothing to work on
in the output directory (nothing was written), or aggregate found finished runs without
a usable analysis, or a results file could not be written after others were; 2 invalid
config or usage, or not enough disk space, or a read-only sweep (nothing was written);
128 + signal number when stopped by a signal (SIGINT 130, SIGTERM 143, SIGUSR1 138) after
every running run wrote a checkpoint, or every earlier result of a results command was
left intact (:func:`fcsweep.io.failures.results_command`).
"""

from fcsweep.cli.main import COMMAND_ORDER, cli, main

__all__ = ["cli", "main", "COMMAND_ORDER"]
