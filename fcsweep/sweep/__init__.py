"""Running sweeps: one run (:mod:`fcsweep.sweep.runner`), many runs on executors
(:mod:`fcsweep.sweep.executors`) with the options of one frozen record
(:mod:`fcsweep.sweep.options`), the dry run (:mod:`fcsweep.sweep.plan`), the step's cost
(:mod:`fcsweep.sweep.bench`), status tables (:mod:`fcsweep.sweep.status`) and progress
display (:mod:`fcsweep.sweep.progress`)."""

from fcsweep.sweep.executors import run_sweep, select_runs
from fcsweep.sweep.options import SweepOptions
from fcsweep.sweep.runner import RunOutcome, run_one
from fcsweep.sweep.status import collect_status, format_status

__all__ = ["run_sweep", "select_runs", "SweepOptions", "run_one", "RunOutcome", "collect_status", "format_status"]
