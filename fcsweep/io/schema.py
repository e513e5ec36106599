"""Names shared by the writers, readers and documentation of a sweep directory."""

from __future__ import annotations

#: File names inside ``<output>/runs/<run_id>/``.
TRAJECTORY = "trajectory.h5"
TRAJECTORY_PARTIAL = "trajectory.h5.partial"
CHECKPOINT = "checkpoint.npz"
STATUS = "status.json"
LOCK = "run.lock"
ANALYSIS = "analysis.h5"
#: Attribute of ``analysis.h5`` holding the analysis settings it was made with (JSON).
ANALYSIS_SETTINGS_ATTR = "settings_json"
#: Attribute of ``analysis.h5`` holding the revision of the label rules it was made with.
LABEL_RULES_ATTR = "label_rules"
#: Revision of the label rules: raised whenever a rule change can alter the labels of data
#: already analysed, so that such analyses read as stale and ``fcsweep analyze`` redoes them
#: (the revisions are listed in CHANGELOG.md).
LABEL_RULES = 3
#: Written by a failed analysis (``fcsweep.results.analyze.ANALYSIS_ERROR_FILE``).
ANALYSIS_ERROR = "analysis_error.txt"
#: File names inside ``<output>/``: the aggregated dataset and the points ``fcsweep refine`` added.
DATASET = "phase_diagram.nc"
REFINEMENT = "refinement.json"

#: Group of the particle time series and the box.
PARTICLES = "/particles/cells"
OBSERVABLES = "/observables"
PARAMETERS = "/parameters"

#: H5MD version written.
H5MD_VERSION = (1, 1)

#: Status values of a run (``status.json`` key ``status``).
#:
#: Life cycle::
#:
#:     pending -> running -> done
#:                  |-> interrupted (signal; resumes from the checkpoint at the signal)
#:                  |-> failed      (``cause``: "simulation" is final until --retry-failed;
#:                  |                "io" resumes by itself once the disk/quota is fixed)
#:     done -> corrupt (trajectory fails its checksums; the next simulate recomputes it)
DONE, FAILED, RUNNING, PENDING = "done", "failed", "running", "pending"
INTERRUPTED, CORRUPT = "interrupted", "corrupt"
STATUSES = (DONE, FAILED, RUNNING, PENDING, INTERRUPTED, CORRUPT)

#: ``status.json`` keys of a run's cost, kept through every state change: wall and CPU
#: seconds of all attempts, CPU seconds of the ``run.until`` checks, cell-steps in the
#: trajectory (N x steps done) and cell-steps integrated (including work redone after kills).
COST_KEYS = ("wall_seconds", "cpu_seconds", "check_cpu_seconds", "cell_steps", "cell_steps_computed")

#: ``status.json`` key ``cause`` of a failed run.
CAUSE_SIMULATION, CAUSE_IO = "simulation", "io"

#: H5MD units module: the unit system and the unit strings (H5MD grammar: space-separated
#: factors, each a symbol of letters with an optional signed integer power, so "R0" would
#: not parse).  Lengths are in units of the cell radius R0 (symbol "radius"), times in
#: units of tau = R0 / (mobility x force unit) (symbol "tau"), the model's reduced units.
#: Dimensionless datasets carry no ``unit`` attribute.
UNIT_SYSTEM = "reduced"
LENGTH_UNIT = "radius"
TIME_UNIT = "tau"

#: Per-cell time series: name -> (dtype, trailing shape key, unit or None, description).
#: Trailing shape: "2" -> (N, 2); "" -> (N,); "modes" -> (N, M-1).
FIELD_LAYOUT = {
    "position": ("float64", "2", LENGTH_UNIT, "cell polar origin r_i, wrapped into [0,Lx) x [0,Ly)"),
    "image": ("int32", "2", None, "periodic box crossings; unwrapped = position + image * edges"),
    "theta": ("float64", "", "rad", "polarity angle theta_i, unwrapped (not reduced mod 2 pi)"),
    "shape_a": ("float64", "modes", None, "Fourier amplitudes a_n, n = 2..M (column k is n = k+2)"),
    "shape_b": ("float64", "modes", None, "Fourier amplitudes b_n, n = 2..M (column k is n = k+2)"),
}
