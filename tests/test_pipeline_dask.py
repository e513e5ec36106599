"""`fcsweep simulate --executor dask` against a LocalCluster on loopback."""

from __future__ import annotations

import h5py
import numpy as np
import pytest
from click.testing import CliRunner

from fcsweep.cli import cli
from fcsweep.config import load_config
from fcsweep.io import schema
from fcsweep.sweep.executors import run_sweep

distributed = pytest.importorskip("distributed")

CONFIG = """
output: {out}
seed: 21
grid:
  v0: [0.03, 0.06]
  eta: [0.1]
model: {{N: 16}}
run: {{steps: 200, sample_every: 20, checkpoint_every: 100}}
"""


def test_dask_local_cluster_matches_serial(tmp_path):
    path = tmp_path / "sweep.yaml"
    path.write_text(CONFIG.format(out=tmp_path / "dask"))
    cfg = load_config(path)
    ref = cfg.with_output(tmp_path / "serial")
    run_sweep(ref, ref.runs())
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False, host="127.0.0.1",
                                  protocol="tcp", dashboard_address=None) as cluster:
        assert cluster.scheduler_address.startswith("tcp://127.0.0.1:")
        args = ["simulate", str(path), "--executor", "dask", "--scheduler", cluster.scheduler_address]
        r = CliRunner().invoke(cli, args)
        assert r.exit_code == 0, r.output
        assert "[dask]" in r.output and "2 computed" in r.output
        r2 = CliRunner().invoke(cli, args)  # resubmission: everything already done
        assert r2.exit_code == 0 and "0 computed, 2 already done" in r2.output
    for s in cfg.runs():
        with h5py.File(cfg.run_dir(s.run_id) / schema.TRAJECTORY, "r") as a, \
                h5py.File(ref.run_dir(s.run_id) / schema.TRAJECTORY, "r") as b:
            for k in ("position", "image", "theta", "shape_a"):
                assert np.array_equal(a[f"particles/cells/{k}/value"][()], b[f"particles/cells/{k}/value"][()])


def test_dask_needs_scheduler(tmp_path):
    path = tmp_path / "sweep.yaml"
    path.write_text(CONFIG.format(out=tmp_path / "x"))
    r = CliRunner().invoke(cli, ["simulate", str(path), "--executor", "dask"])
    assert r.exit_code == 2 and "--scheduler" in r.output
    assert not (tmp_path / "x").exists()
