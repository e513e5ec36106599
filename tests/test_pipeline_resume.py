"""Never lose work: SIGKILL at chosen moments, resume, and compare bit for bit.

The subprocesses kill themselves with a real SIGKILL at a precise point of the run
(``FCSWEEP_TEST_KILL_AT``, see :mod:`fcsweep.sweep.runner`), including in the middle of
an HDF5 append and between writing and renaming a checkpoint; one more is killed from
outside at whatever moment it has reached.  Each interrupted run is then completed by an
ordinary ``simulate`` and its trajectory compared with an uninterrupted run, dataset by
dataset, for exact equality.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import h5py
import numpy as np
import pytest

from fcsweep.config import load_config
from fcsweep.io import schema
from fcsweep.io.status import read_status
from fcsweep.sweep.executors import run_sweep

CONFIG = """
output: {out}
seed: 11
grid:
  v0: [0.02, 0.03, 0.04, 0.05, 0.06, 0.07]
model: {{N: 16, eta: 0.1}}
run: {{steps: 400, sample_every: 20, checkpoint_every: 100}}
"""

#: run index -> kill point (K-th time the point is reached)
KILLS = {
    0: "frame:7",              # between checkpoints: frames 6-7 buffered, ckpt at step 100
    1: "h5-append:2",          # datasets grown for checkpoint 2, data not written
    2: "checkpoint-write:2",   # temporary checkpoint written, not renamed
    3: "checkpoint:3",         # right after checkpoint 3 replaced
    4: "finalize:1",           # trajectory renamed, status.json not yet 'done'
}


def _datasets(path) -> dict[str, np.ndarray]:
    out = {}
    with h5py.File(path, "r") as f:
        def visit(name, obj):
            if isinstance(obj, h5py.Dataset) and not name.startswith("parameters"):
                out[name] = obj[()]
        f.visititems(visit)
    return out


def assert_same_trajectory(a, b):
    da, db = _datasets(a), _datasets(b)
    assert sorted(da) == sorted(db)
    for k in da:
        assert da[k].dtype == db[k].dtype and da[k].shape == db[k].shape, k
        assert np.array_equal(da[k], db[k]), f"{k} differs"


@pytest.fixture(scope="module")
def sweep(tmp_path_factory):
    root = tmp_path_factory.mktemp("resume")
    cfg_path = root / "sweep.yaml"
    cfg_path.write_text(CONFIG.format(out=root / "killed"))
    cfg = load_config(cfg_path)
    ref = cfg.with_output(root / "reference")
    outs = run_sweep(ref, ref.runs())
    assert all(o.outcome == "done" for o in outs)
    return cfg_path, cfg, ref


def _simulate(cfg_path, *extra, env=None):
    return subprocess.Popen(
        [sys.executable, "-m", "fcsweep.cli", "simulate", str(cfg_path), "-q", *extra],
        env={**os.environ, **(env or {})}, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
    )


def test_sigkill_at_chosen_points_then_resume_is_bitwise(sweep):
    cfg_path, cfg, ref = sweep
    procs = {i: _simulate(cfg_path, "--task-index", str(i), env={"FCSWEEP_TEST_KILL_AT": point})
             for i, point in KILLS.items()}
    runs = cfg.runs()
    for i, p in procs.items():
        out, _ = p.communicate(timeout=120)
        assert p.returncode == -signal.SIGKILL, f"run {i} ({KILLS[i]}) was not killed:\n{out}"
    d = {i: cfg.run_dir(runs[i].run_id) for i in KILLS}
    # what the kills left behind
    assert (d[0] / schema.TRAJECTORY_PARTIAL).exists() and not (d[0] / schema.TRAJECTORY).exists()
    assert list(d[2].glob(".checkpoint.npz.*.tmp")), "checkpoint temp file should be left by the kill"
    assert (d[4] / schema.TRAJECTORY).exists() and read_status(d[4])["status"] == "running"

    outcomes = run_sweep(cfg, runs)  # the ordinary re-run completes everything
    assert [o.outcome for o in outcomes] == ["done"] * len(runs)
    assert "recovered finished trajectory" in outcomes[4].message
    assert "resumed from step 100" in outcomes[0].message
    assert "resumed from step 100" in outcomes[1].message  # append of ckpt 2 was lost, ckpt 1 holds
    assert "resumed from step 100" in outcomes[2].message  # temp ckpt 2 never renamed
    assert "resumed from step 300" in outcomes[3].message
    for spec in runs:
        assert_same_trajectory(cfg.run_dir(spec.run_id) / schema.TRAJECTORY,
                               ref.run_dir(spec.run_id) / schema.TRAJECTORY)
        leftovers = {p.name for p in cfg.run_dir(spec.run_id).iterdir()}
        assert leftovers == {schema.TRAJECTORY, schema.CHECKPOINT, schema.STATUS}, leftovers
        st = read_status(cfg.run_dir(spec.run_id))
        assert st["status"] == "done" and st["steps_done"] == 400


def test_external_sigkill_mid_run_then_resume(sweep, tmp_path):
    """Kill from outside as soon as the first checkpoint exists (an arbitrary moment)."""
    _, cfg, ref = sweep
    cfg = cfg.with_output(tmp_path / "ext")
    spec = cfg.runs()[5]
    cfg_file = tmp_path / "c.yaml"
    cfg_file.write_text(CONFIG.format(out=cfg.output))
    p = _simulate(cfg_file, "--task-index", "5", env={"FCSWEEP_TEST_SLOW": "0.03"})
    ck = cfg.run_dir(spec.run_id) / schema.CHECKPOINT
    t0 = time.time()
    while not ck.exists() and p.poll() is None and time.time() - t0 < 60:
        time.sleep(0.002)
    time.sleep(0.05)
    p.send_signal(signal.SIGKILL)
    p.communicate(timeout=60)
    assert p.returncode == -signal.SIGKILL
    (o,) = run_sweep(cfg, [spec])
    assert o.outcome == "done" and "resumed from step" in o.message
    assert_same_trajectory(cfg.run_dir(spec.run_id) / schema.TRAJECTORY,
                           ref.run_dir(spec.run_id) / schema.TRAJECTORY)


def test_corrupt_partial_trajectory_restarts_from_scratch(sweep, tmp_path):
    """A partial HDF5 file that cannot be read is not tripped over: the run starts again."""
    _, cfg, ref = sweep
    cfg = cfg.with_output(tmp_path / "corrupt")
    spec = cfg.runs()[1]
    cfg_file = tmp_path / "c.yaml"
    cfg_file.write_text(CONFIG.format(out=cfg.output))
    p = _simulate(cfg_file, "--task-index", "1", env={"FCSWEEP_TEST_KILL_AT": "frame:12"})
    p.communicate(timeout=120)
    assert p.returncode == -signal.SIGKILL
    partial = cfg.run_dir(spec.run_id) / schema.TRAJECTORY_PARTIAL
    with open(partial, "r+b") as fh:  # wreck the superblock
        fh.write(b"\0" * 512)
    (o,) = run_sweep(cfg, [spec])
    assert o.outcome == "done" and "restarted from step 0" in o.message
    assert_same_trajectory(cfg.run_dir(spec.run_id) / schema.TRAJECTORY,
                           ref.run_dir(spec.run_id) / schema.TRAJECTORY)


def test_sigterm_releases_lock_and_run_resumes(sweep, tmp_path):
    """A batch time limit (SIGTERM) leaves an interrupted run with no lock, resumable."""
    from click.testing import CliRunner

    from fcsweep.cli import cli

    _, cfg, ref = sweep
    cfg = cfg.with_output(tmp_path / "term")
    spec = cfg.runs()[3]
    cfg_file = tmp_path / "c.yaml"
    cfg_file.write_text(CONFIG.format(out=cfg.output))
    p = _simulate(cfg_file, "--task-index", "3", env={"FCSWEEP_TEST_SLOW": "0.05"})
    ck = cfg.run_dir(spec.run_id) / schema.CHECKPOINT
    t0 = time.time()
    while not ck.exists() and p.poll() is None and time.time() - t0 < 60:
        time.sleep(0.002)
    p.send_signal(signal.SIGTERM)
    p.communicate(timeout=60)
    assert p.returncode == 128 + signal.SIGTERM
    assert not (cfg.run_dir(spec.run_id) / schema.LOCK).exists()
    r = CliRunner().invoke(cli, ["status", str(cfg_file)])
    assert f"{spec.run_id}  interrupted" in r.output
    (o,) = run_sweep(cfg, [spec])
    assert o.outcome == "done" and "resumed from step" in o.message
    assert_same_trajectory(cfg.run_dir(spec.run_id) / schema.TRAJECTORY,
                           ref.run_dir(spec.run_id) / schema.TRAJECTORY)
