"""Names shared by the writers, readers and documentation of a sweep directory."""

from __future__ import annotations

#: File names inside ``<output>/runs/<run_id>/``.
TRAJECTORY = "trajectory.h5"
TRAJECTORY_PARTIAL = "trajectory.h5.partial"
CHECKPOINT = "checkpoint.npz"
STATUS = "status.json"
LOCK = "run.lock"
ANALYSIS = "analysis.h5"

#: Group of the particle time series and the box.
PARTICLES = "/particles/cells"
OBSERVABLES = "/observables"
PARAMETERS = "/parameters"

#: H5MD version written.
H5MD_VERSION = (1, 1)

#: Status values of a run.
DONE, FAILED, RUNNING, PENDING = "done", "failed", "running", "pending"
STATUSES = (DONE, FAILED, RUNNING, PENDING)

#: Per-cell time series: name -> (dtype, trailing shape key, unit, description).
#: Trailing shape: "2" -> (N, 2); "" -> (N,); "modes" -> (N, M-1).
FIELD_LAYOUT = {
    "position": ("float64", "2", "R0", "cell polar origin r_i, wrapped into [0,Lx) x [0,Ly)"),
    "image": ("int32", "2", "1", "periodic box crossings; unwrapped = position + image * edges"),
    "theta": ("float64", "", "rad", "polarity angle theta_i, unwrapped (not reduced mod 2 pi)"),
    "shape_a": ("float64", "modes", "1", "Fourier amplitudes a_n, n = 2..M (column k is n = k+2)"),
    "shape_b": ("float64", "modes", "1", "Fourier amplitudes b_n, n = 2..M (column k is n = k+2)"),
}
