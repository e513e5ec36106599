"""Nothing lost, nothing silently wrong: signals, full disks, damaged files, stale locks,
and H5MD files that other tools accept.

Trajectories computed after a fault are compared with an uninterrupted reference, dataset
by dataset, for exact equality (runs are deterministic)."""

from __future__ import annotations

import errno
import json
import os
import re
import signal
import socket
import subprocess
import sys
import time

import h5py
import pytest
from click.testing import CliRunner

from fcsweep.cli import cli
from fcsweep.config import load_config
from fcsweep.io import schema
from fcsweep.io.checkpoint import load_checkpoint, split_meta
from fcsweep.io.locks import lock_info, lock_is_stale
from fcsweep.io.rundir import RunDirectory, io_error_cause
from fcsweep.io.status import read_status
from fcsweep.sweep import runner
from fcsweep.sweep.executors import run_sweep, unfinished
from fcsweep.sweep.runner import RunOutcome
from test_pipeline_resume import assert_same_trajectory

CONFIG = """
output: {out}
seed: 21
grid:
  v0: [0.03, 0.05, 0.07]
model: {{N: 16, eta: 0.1}}
run: {{steps: 400, sample_every: 20, checkpoint_every: 100}}
"""


@pytest.fixture(scope="module")
def sweep(tmp_path_factory):
    root = tmp_path_factory.mktemp("faults")
    cfg_path = root / "sweep.yaml"
    cfg_path.write_text(CONFIG.format(out=root / "reference"))
    ref = load_config(cfg_path)
    assert all(o.outcome == "done" for o in run_sweep(ref, ref.runs()))
    return ref


def _copy_config(tmp_path, ref, name="out"):
    cfg_path = tmp_path / "c.yaml"
    cfg_path.write_text(CONFIG.format(out=tmp_path / name))
    return cfg_path, load_config(cfg_path)


def _wait_for(pred, timeout=120.0):
    t0 = time.time()
    while not pred():
        if time.time() - t0 > timeout:
            raise AssertionError("timed out")
        time.sleep(0.02)


@pytest.mark.parametrize("sig,code", [(signal.SIGTERM, 143), (signal.SIGINT, 130)])
def test_signal_checkpoints_at_current_step_and_resumes_bitwise(sweep, tmp_path, sig, code):
    cfg_path, cfg = _copy_config(tmp_path, sweep)
    spec = cfg.runs()[1]
    run_dir = cfg.run_dir(spec.run_id)
    p = subprocess.Popen([sys.executable, "-m", "fcsweep.cli", "simulate", str(cfg_path), "--task-index", "1", "-q"],
                         env={**os.environ, "FCSWEEP_TEST_SLOW": "0.2"}, stdout=subprocess.PIPE,
                         stderr=subprocess.STDOUT, text=True)
    _wait_for(lambda: (read_status(run_dir) or {}).get("steps_done", 0) >= 40)
    t0 = time.time()
    p.send_signal(sig)
    out, _ = p.communicate(timeout=30)
    assert time.time() - t0 < 10, "the signal took more than 10 s to stop the run"
    assert p.returncode == code, out
    assert f"resume with: fcsweep simulate {cfg_path}" in out
    assert "Traceback" not in out and "Aborted" not in out
    st = read_status(run_dir)
    assert st["status"] == "interrupted" and st["signal"] == signal.Signals(sig).name
    _, meta = split_meta(load_checkpoint(run_dir / schema.CHECKPOINT))
    assert meta["step"] == st["checkpoint_step"] == st["steps_done"] > 0
    assert not (run_dir / schema.LOCK).exists()
    (o,) = run_sweep(cfg, [spec])
    assert o.outcome == "done" and f"resumed from step {meta['step']}" in o.message
    assert_same_trajectory(run_dir / schema.TRAJECTORY, sweep.run_dir(spec.run_id) / schema.TRAJECTORY)


def test_pool_stops_within_seconds_and_starts_no_new_run(sweep, tmp_path):
    cfg_path, cfg = _copy_config(tmp_path, sweep)
    p = subprocess.Popen([sys.executable, "-m", "fcsweep.cli", "simulate", str(cfg_path), "--workers", "2",
                          "--log-every", "1000"], env={**os.environ, "FCSWEEP_TEST_SLOW": "0.2"},
                         stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    dirs = [cfg.run_dir(s.run_id) for s in cfg.runs()]
    _wait_for(lambda: sum((read_status(d) or {}).get("status") == "running" for d in dirs) >= 1, timeout=180)
    t0 = time.time()
    p.send_signal(signal.SIGTERM)
    out, _ = p.communicate(timeout=60)
    assert time.time() - t0 < 15, out
    assert p.returncode == 143, out
    states = [(read_status(d) or {}).get("status") for d in dirs]
    assert "done" not in states and "running" not in states, states
    assert states.count("interrupted") >= 1
    assert not any((d / schema.LOCK).exists() for d in dirs if d.exists())


def _fail_second_append(monkeypatch, err=errno.ENOSPC):
    calls = {"n": 0}
    real = runner.append_frames

    def flaky(*a, **k):
        calls["n"] += 1
        if calls["n"] == 2:
            raise OSError(err, os.strerror(err), str(a[0]))
        return real(*a, **k)

    monkeypatch.setattr(runner, "append_frames", flaky)


@pytest.mark.parametrize("err", [errno.ENOSPC, errno.EIO, errno.EDQUOT, errno.EROFS])
def test_io_error_marks_failed_with_cause_then_resumes(sweep, tmp_path, monkeypatch, err):
    _, cfg = _copy_config(tmp_path, sweep)
    spec = cfg.runs()[0]
    run_dir = cfg.run_dir(spec.run_id)
    _fail_second_append(monkeypatch, err)
    (o,) = run_sweep(cfg, [spec])
    assert o.outcome == "failed" and os.strerror(err).lower().split()[0] in o.message.lower()
    assert "resumes from step 100" in o.message
    st = read_status(run_dir)
    assert st["status"] == "failed" and st["cause"] == "io" and not (run_dir / schema.LOCK).exists()
    monkeypatch.undo()
    (o,) = run_sweep(cfg, [spec])  # no --retry-failed needed for an I/O failure
    assert o.outcome == "done" and "resumed from step 100" in o.message
    assert_same_trajectory(run_dir / schema.TRAJECTORY, sweep.run_dir(spec.run_id) / schema.TRAJECTORY)


def test_io_error_cause_reads_hdf5_messages():
    assert io_error_cause(OSError("Can't write data (file write failed: errno = 28, error message = 'x')"))
    assert io_error_cause(OSError(errno.EDQUOT, "Disk quota exceeded")) == "disk quota exceeded"
    assert io_error_cause(ValueError("x")) is None


def _tmpfs(path, size):
    path.mkdir()
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(path)], capture_output=True)
    if r.returncode != 0:
        pytest.skip("cannot mount a tmpfs here")
    return path


def test_sweep_that_cannot_fit_is_refused_with_exit_2(tmp_path):
    mnt = _tmpfs(tmp_path / "small", "1m")
    try:
        cfg_path = tmp_path / "big.yaml"
        cfg_path.write_text(CONFIG.format(out=mnt / "out").replace("N: 16", "N: 1024"))
        r = CliRunner().invoke(cli, ["simulate", str(cfg_path)])
        assert r.exit_code == 2 and "not enough disk space" in r.output, r.output
        assert not (mnt / "out").exists()
    finally:
        subprocess.run(["umount", str(mnt)])


def test_real_full_disk_fails_cleanly_then_resumes(sweep, tmp_path):
    """A tmpfs that fills up while the run computes (a file written beside it)."""
    mnt = _tmpfs(tmp_path / "small", "8m")
    try:
        cfg_path, cfg = _copy_config(tmp_path, sweep)
        cfg = cfg.with_output(mnt / "out")
        spec = cfg.runs()[2]
        filler = mnt / "filler"
        p = subprocess.Popen([sys.executable, "-m", "fcsweep.cli", "simulate", str(cfg_path), "-o", str(cfg.output),
                              "--task-index", "2", "-q"], env={**os.environ, "FCSWEEP_TEST_SLOW": "0.1"},
                             stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        ck = cfg.run_dir(spec.run_id) / schema.CHECKPOINT
        _wait_for(ck.exists)
        with open(filler, "wb") as fh:  # take every free byte
            try:
                while True:
                    fh.write(b"\0" * 65536)
                    fh.flush()
            except OSError:
                pass
        out, _ = p.communicate(timeout=120)
        assert p.returncode == 1, out
        assert "no space left on device" in out.lower() and "Traceback" not in out
        run_dir = cfg.run_dir(spec.run_id)
        assert not (run_dir / schema.LOCK).exists()
        filler.unlink()
        (o,) = run_sweep(cfg, [spec])
        assert o.outcome == "done" and "resumed from step" in o.message, o.message
        assert_same_trajectory(run_dir / schema.TRAJECTORY, sweep.run_dir(spec.run_id) / schema.TRAJECTORY)
    finally:
        subprocess.run(["umount", str(mnt)])


@pytest.mark.parametrize("damage", ["flip", "truncate"])
def test_damaged_trajectory_detected_marked_corrupt_and_recomputed(sweep, tmp_path, damage):
    cfg_path, cfg = _copy_config(tmp_path, sweep)
    spec = cfg.runs()[0]
    assert run_sweep(cfg, [spec])[0].outcome == "done"
    traj = cfg.run_dir(spec.run_id) / schema.TRAJECTORY
    data = bytearray(traj.read_bytes())
    if damage == "flip":
        with h5py.File(traj, "r") as f:
            off = f["particles/cells/position/value"].id.get_chunk_info(0).byte_offset
        data[off + 16:off + 24] = bytes(b ^ 0xFF for b in data[off + 16:off + 24])
    else:
        data = data[: len(data) * 2 // 3]
    traj.write_bytes(bytes(data))
    r = CliRunner().invoke(cli, ["status", str(cfg_path), "--verify"])
    assert r.exit_code == 1 and re.search(rf"{spec.run_id}\s+corrupt", r.output), r.output
    assert read_status(cfg.run_dir(spec.run_id))["status"] == "corrupt"
    (o,) = run_sweep(cfg, [spec])
    assert o.outcome == "done"
    assert_same_trajectory(traj, sweep.run_dir(spec.run_id) / schema.TRAJECTORY)
    # simulate alone (no status --verify first) notices a damaged done run too
    traj.write_bytes(traj.read_bytes()[:-4096])
    (o,) = run_sweep(cfg, [spec])
    assert o.outcome == "done" and "recomputed damaged trajectory" in o.message
    assert RunDirectory(traj.parent, spec.run_id, 0).verify(cfg.run.n_frames) is None


def test_lock_staleness_by_heartbeat_on_any_host(tmp_path):
    lock = tmp_path / "run.lock"
    lock.write_text(json.dumps({"pid": 1, "host": "another-node", "token": "t", "started": "x"}))
    assert not lock_is_stale(lock_info(lock), stale_after=60)
    old = time.time() - 61
    os.utime(lock, (old, old))
    assert lock_is_stale(lock_info(lock), stale_after=60)
    # this host, dead pid: stale at once
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    lock.write_text(json.dumps({"pid": int(dead.stdout), "host": socket.gethostname(), "token": "t"}))
    assert lock_is_stale(lock_info(lock), stale_after=3600)


def test_sweep_names_runs_left_unfinished_by_a_dead_holder(sweep, tmp_path):
    _, cfg = _copy_config(tmp_path, sweep)
    spec = cfg.runs()[0]
    d = cfg.run_dir(spec.run_id)
    d.mkdir(parents=True)
    (d / schema.LOCK).write_text(json.dumps({"pid": 1, "host": "another-node", "token": "t"}))
    o = RunOutcome(spec.index, spec.run_id, "locked", "held by pid 1 on another-node")
    assert unfinished(cfg, [o]) == []  # fresh heartbeat: live
    old = time.time() - 3600
    os.utime(d / schema.LOCK, (old, old))
    assert unfinished(cfg, [o]) == [o]


def test_h5md_layout_strings_units_links_checksums_and_size(sweep, tmp_path):
    spec = sweep.runs()[0]
    traj = sweep.run_dir(spec.run_id) / schema.TRAJECTORY
    unit_re = re.compile(r"^([0-9.]+( |$))?([A-Za-z]+([+-][1-9][0-9]*)?( |$))*$")
    with h5py.File(traj, "r") as f:
        cells = f["particles/cells"]
        for name in ("image", "theta", "shape_a", "shape_b"):
            assert cells[f"{name}/step"].id == cells["position/step"].id  # hard links, not copies
            assert cells[f"{name}/time"].id == cells["position/time"].id
        assert f["observables/projections/step"].id == cells["position/step"].id

        def vlen_ascii(obj, attr):
            t = h5py.h5a.open(obj.id, attr.encode()).get_type()
            return t.get_class() == h5py.h5t.STRING and t.is_variable_str() and t.get_cset() == h5py.h5t.CSET_ASCII

        assert vlen_ascii(f["h5md/creator"], "name") and vlen_ascii(f["h5md/creator"], "version")
        assert vlen_ascii(f["h5md/author"], "name") and vlen_ascii(cells["box"], "boundary")
        assert vlen_ascii(f["h5md/modules/units"], "system")
        assert list(f["h5md"].attrs["version"]) == [1, 1]
        datasets = []
        f.visititems(lambda n, o: datasets.append(o) if isinstance(o, h5py.Dataset) else None)
        for ds in datasets:
            assert ds.fletcher32, ds.name
            if "unit" in ds.attrs:
                assert vlen_ascii(ds, "unit") and unit_re.match(ds.attrs["unit"]), (ds.name, ds.attrs["unit"])
        par = f["parameters"].attrs
        assert int(par["seed"]) == spec.seed and int(par["complete"]) == 1
    with h5py.File(traj, "r") as f, h5py.File(tmp_path / "copy.h5", "w") as g:
        for k in f:
            f.copy(f[k], g)
    assert traj.stat().st_size <= 1.25 * (tmp_path / "copy.h5").stat().st_size
