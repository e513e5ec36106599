"""Running sweeps: one run (:mod:`.runner`), many runs on executors (:mod:`.executors`),
status tables (:mod:`fcsweep.sweep.status`) and progress display (:mod:`.progress`)."""

from fcsweep.sweep.executors import run_sweep, select_runs
from fcsweep.sweep.runner import RunOutcome, run_one
from fcsweep.sweep.status import collect_status, format_status

__all__ = ["run_sweep", "select_runs", "run_one", "RunOutcome", "collect_status", "format_status"]
