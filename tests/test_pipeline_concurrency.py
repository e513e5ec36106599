"""Two `fcsweep simulate` processes on one config (overlapping cron jobs, a resubmitted
array) compute every run exactly once and leave intact files."""

from __future__ import annotations

import os
import re
import subprocess
import sys

import h5py

from fcsweep.config import load_config
from fcsweep.io import schema
from fcsweep.io.status import read_status

CONFIG = """
output: {out}
seed: 9
grid:
  eta: [0.05, 0.1]
  v0: [0.02, 0.04, 0.06]
model: {{N: 36}}
run: {{steps: 300, sample_every: 20, checkpoint_every: 100}}
"""


def test_two_concurrent_launches_compute_each_run_once(tmp_path):
    from fcsweep.simulation import Simulation

    Simulation.from_lattice(16, eta=0.1, v0=0.03, seed=0).advance(1)  # fill numba's cache first
    path = tmp_path / "sweep.yaml"
    path.write_text(CONFIG.format(out=tmp_path / "out"))
    cfg = load_config(path)
    cmd = [sys.executable, "-m", "fcsweep.cli", "simulate", str(path), "--log-every", "1000"]
    procs = [subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                              env={**os.environ, "PYTHONUNBUFFERED": "1"}) for _ in range(2)]
    outs = [p.communicate(timeout=300)[0] for p in procs]
    print(*outs, sep="\n----\n")
    assert [p.returncode for p in procs] == [0, 0], outs
    computed = [re.findall(r"run \d+ (\w{12}) \[.*\] computed", o) for o in outs]
    ids = [s.run_id for s in cfg.runs()]
    # every run computed by exactly one of the two processes
    assert sorted(computed[0] + computed[1]) == sorted(ids), outs
    for o in outs:  # the other process only ever skipped it (held, or already done)
        n_skip = len(re.findall(r"skipped \((already done|held by another process)\)", o))
        assert n_skip + len(re.findall(r" computed in ", o)) == len(ids), o
    for rid in ids:
        st = read_status(cfg.run_dir(rid))
        assert st["status"] == "done" and st["attempts"] == 1
        with h5py.File(cfg.run_dir(rid) / schema.TRAJECTORY, "r") as f:
            assert f["particles/cells/position/value"].shape == (16, 36, 2)
            assert f["parameters"].attrs["complete"] == 1
        assert not (cfg.run_dir(rid) / schema.LOCK).exists()
