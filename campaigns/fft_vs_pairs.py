"""KTHNY from the FFT correlations against the pair counts of runs already analysed.

    python campaigns/fft_vs_pairs.py RUNS_DIR OUT_DIR

For every ``RUNS_DIR/<id>/trajectory.h5`` with an ``analysis.h5`` made with the pair counts,
analyses the run again with the same settings but ``correlations: fft`` into
``OUT_DIR/<id>.h5`` (the run's own files are not touched) and prints the KTHNY label, its
confidence and the exponents of both, with the CPU seconds of the FFT analysis.
"""

import json
import sys
import time
from pathlib import Path

import h5py

from fcsweep.results.analyze import analyze_run

runs = sorted(Path(sys.argv[1]).glob("*/trajectory.h5"))
keys = ("kthny", "kthny_confidence", "eta_G1", "eta_G1_err", "eta_6", "eta_6_err", "eta_T", "eta_T_err", "psi6")
for traj in runs:
    rid = traj.parent.name
    with h5py.File(traj.parent / "analysis.h5", "r") as f:
        settings = json.loads(f.attrs["settings_json"])
        pairs = {k: float(f["observables"].attrs[k]) for k in keys}
        params = json.loads(f.attrs["parameters_json"])
    settings["correlations"] = "fft"
    out = Path(sys.argv[2]) / f"{rid}.h5"
    t = time.process_time()
    analyze_run(traj, out, settings=settings, force=True)
    cpu = time.process_time() - t
    with h5py.File(out, "r") as f:
        fft = {k: float(f["observables"].attrs[k]) for k in keys}
        reason = f["observables"].attrs["kthny_reason"]
    print(f"{rid} v0={params['v0']} initial={params.get('initial')} cpu={cpu:.0f}s")
    for k in keys:
        print(f"   {k:18s} pairs {pairs[k]: .4g}   fft {fft[k]: .4g}")
    print("   fft reason:", reason, flush=True)
