"""Running sweeps: one run (:mod:`.runner`), many runs on executors (:mod:`.executors`)
with the options of one frozen record (:mod:`.options`), the dry run (:mod:`.plan`), the
step's cost (:mod:`.bench`), status tables (:mod:`.status`) and progress display
(:mod:`.progress`)."""

from fcsweep.sweep.executors import run_sweep, select_runs
from fcsweep.sweep.options import SweepOptions
from fcsweep.sweep.runner import RunOutcome, run_one
from fcsweep.sweep.status import collect_status, format_status

__all__ = ["run_sweep", "select_runs", "SweepOptions", "run_one", "RunOutcome", "collect_status", "format_status"]
