"""Sweep pipeline: H5MD layout read back with plain h5py, checkpoints, locks, failed-run
isolation and --retry-failed, status table, process pool, progress output."""

from __future__ import annotations

import io
import json
import os
import socket
import subprocess
import time

import h5py
import numpy as np
import pytest
from click.testing import CliRunner

from fcsweep.cli import cli
from fcsweep.config import load_config
from fcsweep.io import schema
from fcsweep.io.checkpoint import load_checkpoint, save_checkpoint
from fcsweep.io.locks import RunLock, lock_info, lock_is_stale
from fcsweep.io.status import read_status
from fcsweep.sweep.executors import run_sweep
from fcsweep.sweep.progress import Progress

CONFIG = """
output: {out}
seed: 5
grid:
  eta: [0.1]
  v0: [0.03, 0.06]
  modes: [6, 0]
model: {{N: 16}}
run: {{steps: 200, sample_every: 20, checkpoint_every: 100}}
"""


def _same(a, b):
    with h5py.File(a, "r") as fa, h5py.File(b, "r") as fb:
        for grp in ("particles/cells", "observables"):
            names = []
            fa[grp].visit(names.append)
            for n in names:
                if isinstance(fa[grp][n], h5py.Dataset):
                    assert np.array_equal(fa[grp][n][()], fb[grp][n][()]), n


@pytest.fixture(scope="module")
def done_sweep(tmp_path_factory):
    root = tmp_path_factory.mktemp("pipe")
    path = root / "sweep.yaml"
    path.write_text(CONFIG.format(out=root / "ref"))
    cfg = load_config(path)
    outs = run_sweep(cfg, cfg.runs())
    assert [o.outcome for o in outs] == ["done"] * 4
    return path, cfg


def test_h5md_layout_read_back_with_plain_h5py(done_sweep):
    from fcsweep.simulation import Simulation

    _, cfg = done_sweep
    spec = cfg.runs()[0]
    path = cfg.run_dir(spec.run_id) / schema.TRAJECTORY
    with h5py.File(path, "r") as f:
        assert list(f["h5md"].attrs["version"]) == [1, 1]
        assert f["h5md/creator"].attrs["name"] == "fcsweep"
        assert "version" in f["h5md/creator"].attrs and "name" in f["h5md/author"].attrs
        box = f["particles/cells/box"]
        assert box.attrs["dimension"] == 2
        assert [str(b) for b in box.attrs["boundary"]] == ["periodic", "periodic"]  # VL strings (H5MD 1.1)
        edges = box["edges"][()]
        assert edges.shape == (2,) and edges.dtype == np.float64
        T, N = 11, 16
        layout = {"position": ((T, N, 2), np.float64), "image": ((T, N, 2), np.int32),
                  "theta": ((T, N), np.float64), "shape_a": ((T, N, 5), np.float64),
                  "shape_b": ((T, N, 5), np.float64)}
        for name, (shape, dtype) in layout.items():
            g = f["particles/cells"][name]
            assert g["value"].shape == shape and g["value"].dtype == dtype, name
            assert g["value"].compression == "gzip" and g["value"].chunks is not None
            assert np.array_equal(g["step"][()], np.arange(0, 201, 20))
            assert g["step"].dtype == np.int64
            assert np.allclose(g["time"][()], 0.005 * g["step"][()])
        proj = f["observables/projections/value"][()]
        assert proj.shape == (T,) and np.all(np.diff(proj) >= 0)
        par = f["parameters"].attrs
        for key in ("N", "eta", "v0", "Dr", "density", "dt", "contour_points", "modes", "quadrature", "initial",
                    "R0", "mu_theta", "mu_shape", "steps", "sample_every", "transient", "seed", "run_id",
                    "fcsweep_version", "created", "config_json"):
            assert key in par, key
        assert par["run_id"] == spec.run_id and par["seed"] == spec.seed and par["complete"] == 1
        assert json.loads(par["config_json"])["run"]["steps"] == 200
        pos = f["particles/cells/position/value"][-1]
        img = f["particles/cells/image/value"][-1]
        assert np.all((pos >= 0) & (pos < edges))
    # the last frame is the state of an independent engine run with the same seed
    sim = Simulation.from_lattice(16, **spec.model_params())
    sim.advance(200)
    assert np.array_equal(pos + img * edges, sim.state.unwrapped())
    assert np.allclose(edges, sim.params.box)


def test_rigid_discs_store_no_shape_modes(done_sweep):
    _, cfg = done_sweep
    spec = next(s for s in cfg.runs() if s.params["modes"] == 0)
    with h5py.File(cfg.run_dir(spec.run_id) / schema.TRAJECTORY, "r") as f:
        assert set(f["particles/cells"]) == {"box", "position", "image", "theta"}


def test_rerun_skips_done_runs(done_sweep):
    path, cfg = done_sweep
    before = {s.run_id: os.stat(cfg.run_dir(s.run_id) / schema.TRAJECTORY).st_mtime_ns for s in cfg.runs()}
    result = CliRunner().invoke(cli, ["simulate", str(path)])
    assert result.exit_code == 0, result.output
    assert "0 computed, 4 already done" in result.output
    after = {s.run_id: os.stat(cfg.run_dir(s.run_id) / schema.TRAJECTORY).st_mtime_ns for s in cfg.runs()}
    assert before == after


def test_checkpoint_atomic_and_tolerant(tmp_path):
    p = tmp_path / "c.npz"
    save_checkpoint(p, {"x": np.arange(3), "s": "hi"}, {"frames": 4})
    ck = load_checkpoint(p)
    assert ck["s"] == "hi" and ck["_sweep_frames"] == 4 and np.array_equal(ck["x"], [0, 1, 2])

    def die(tmp):
        raise KeyboardInterrupt  # stands for a kill between write and rename

    with pytest.raises(KeyboardInterrupt):
        save_checkpoint(p, {"x": np.arange(5), "s": "new"}, {"frames": 9}, before_replace=die)
    assert load_checkpoint(p)["_sweep_frames"] == 4  # old checkpoint intact
    p.write_bytes(b"garbage")
    assert load_checkpoint(p) is None


def _dead_pid() -> int:
    p = subprocess.Popen(["true"])
    p.wait()
    return p.pid


def test_locks_exclusive_stale_and_cross_host(tmp_path):
    path = tmp_path / "run.lock"
    a, b = RunLock(path), RunLock(path)
    assert a.acquire()
    assert not b.acquire() and b.held_by["pid"] == os.getpid()
    a.release()
    assert not path.exists() and b.acquire()
    b.release()
    # a lock left by a dead process on this host is taken over
    path.write_text(json.dumps({"pid": _dead_pid(), "host": socket.gethostname(), "started": "x", "token": "t"}))
    c = RunLock(path)
    assert c.acquire() and c.took_over["token"] == "t"
    c.release()
    # another host: live until its heartbeat is older than stale_after
    path.write_text(json.dumps({"pid": 1, "host": "other-node", "started": "x", "token": "u"}))
    assert not RunLock(path, stale_after=60).acquire()
    old = time.time() - 120
    os.utime(path, (old, old))
    assert lock_is_stale(lock_info(path), stale_after=60)
    d = RunLock(path, stale_after=60)
    assert d.acquire() and d.took_over["host"] == "other-node"
    d.release()


def test_run_held_by_live_process_is_skipped_not_failed(done_sweep, tmp_path):
    path, _ = done_sweep
    cfg = load_config(path).with_output(tmp_path / "held")
    spec = cfg.runs()[1]
    cfg.run_dir(spec.run_id).mkdir(parents=True)
    lock = RunLock(cfg.run_dir(spec.run_id) / schema.LOCK)
    assert lock.acquire()  # "another process" (this one) holds run 1
    try:
        result = CliRunner().invoke(cli, ["simulate", str(path), "-o", str(cfg.output), "--task-index", "1"])
        assert result.exit_code == 0, result.output
        assert "held by another process" in result.output and "1 held by other processes" in result.output
        st = CliRunner().invoke(cli, ["status", str(path), "-o", str(cfg.output)])
        assert f"{spec.run_id}  running" in st.output
    finally:
        lock.release()
    assert read_status(cfg.run_dir(spec.run_id)) is None  # nothing computed or written


def test_failed_run_isolated_then_retry_failed(done_sweep, tmp_path, monkeypatch):
    path, _ = done_sweep
    cfg = load_config(path).with_output(tmp_path / "fail")
    specs = cfg.runs()
    bad = specs[2].run_id
    args = ["simulate", str(path), "-o", str(cfg.output)]
    monkeypatch.setenv("FCSWEEP_FAIL_RUN_IDS", bad)
    result = CliRunner().invoke(cli, args)
    assert result.exit_code == 1, result.output
    assert "3 computed" in result.output and "1 failed" in result.output and "--retry-failed" in result.output
    st = read_status(cfg.run_dir(bad))
    assert st["status"] == "failed" and "injected failure" in st["reason"]
    for s in specs:
        if s.run_id != bad:
            assert read_status(cfg.run_dir(s.run_id))["status"] == "done"

    table = CliRunner().invoke(cli, ["status", str(path), "-o", str(cfg.output)])
    assert table.exit_code == 0
    assert f"{bad}  failed" in table.output and "reason: RuntimeError: injected failure" in table.output
    assert table.output.strip().splitlines()[-1] == ("4 runs: 3 done, 0 running, 0 interrupted, 1 failed, "
                                                     "0 corrupt, 0 pending")

    monkeypatch.delenv("FCSWEEP_FAIL_RUN_IDS")
    again = CliRunner().invoke(cli, args)  # a plain rerun does not retry failed runs
    assert again.exit_code == 1 and "failed earlier" in again.output
    retry = CliRunner().invoke(cli, args + ["--retry-failed"])
    assert retry.exit_code == 0, retry.output
    assert "1 run(s)" in retry.output and "1 computed" in retry.output
    assert read_status(cfg.run_dir(bad))["status"] == "done"
    _same(cfg.run_dir(bad) / schema.TRAJECTORY, done_sweep[1].run_dir(bad) / schema.TRAJECTORY)


def test_status_shows_pending_interrupted_and_progress(done_sweep, tmp_path):
    path, _ = done_sweep
    out = tmp_path / "st"
    r = CliRunner().invoke(cli, ["status", str(path), "-o", str(out)])
    assert r.exit_code == 1 and f"nothing simulated in {out.resolve()}: all 4 runs are pending" in r.output
    assert not out.exists()
    cfg = load_config(path).with_output(out)
    spec = cfg.runs()[0]
    d = cfg.run_dir(spec.run_id)
    d.mkdir(parents=True)
    (d / schema.STATUS).write_text(json.dumps({"status": "running", "steps_done": 100, "steps": 200,
                                               "run_id": spec.run_id, "projections": 0}))
    r = CliRunner().invoke(cli, ["status", str(path), "-o", str(out), "--json"])
    rows = json.loads(r.output)
    assert rows[0]["state"] == "interrupted" and rows[0]["steps_done"] == 100
    r = CliRunner().invoke(cli, ["status", str(path), "-o", str(out)])
    assert " 50.0% 100" in r.output and "1 interrupted" in r.output


def test_process_pool_matches_serial(done_sweep, tmp_path, monkeypatch):
    """Also: more workers than cores are capped at the cores (no oversubscription)."""
    monkeypatch.setattr("fcsweep.io.machine.available_cores", lambda: 2)
    path, ref = done_sweep
    out = tmp_path / "pool"
    r = CliRunner().invoke(cli, ["simulate", str(path), "-o", str(out), "--workers", "5"])
    assert r.exit_code == 0, r.output
    assert "--workers 5 is more than the 2 core(s) available; using 2" in r.output
    assert "process, 2 workers" in r.output and "4 computed" in r.output
    cfg = ref.with_output(out)
    for s in cfg.runs():
        _same(cfg.run_dir(s.run_id) / schema.TRAJECTORY, ref.run_dir(s.run_id) / schema.TRAJECTORY)


def test_progress_plain_lines_and_bars():
    buf = io.StringIO()
    p = Progress(2, stream=buf, log_every=0.0)
    assert not p.interactive
    p.update("abc", "eta=0.1", 50, 100)
    p.run_finished("abc", "run 0 abc computed")
    p.close()
    text = buf.getvalue()
    assert "run abc eta=0.1: step 50/100 (50%)" in text and "[1/2] run 0 abc computed" in text
    buf = io.StringIO()
    p = Progress(2, stream=buf, interactive=True)
    p.update("abc", "eta=0.1", 50, 100)
    p.run_finished("abc", "done")
    p.close()
    assert "runs" in buf.getvalue() and "1/2" in buf.getvalue()


def test_heartbeat_thread_refreshes_lock(tmp_path):
    lock = RunLock(tmp_path / "run.lock")
    assert lock.acquire()
    old = time.time() - 1000
    os.utime(lock.path, (old, old))
    lock.start_heartbeat(interval=0.05)
    time.sleep(0.3)
    assert lock_info(lock.path)["age"] < 5
    lock.release()
    assert not lock.path.exists()


def test_run_stops_without_writing_when_lock_is_taken_over(done_sweep, tmp_path):
    """If another process took our lock over (our heartbeat stalled), we stop writing."""
    from fcsweep.sweep.runner import run_one

    path, _ = done_sweep
    cfg = load_config(path).with_output(tmp_path / "lost")
    spec = cfg.runs()[0]
    lock_path = cfg.run_dir(spec.run_id) / schema.LOCK

    def thief(s, step, steps):
        if step == 60:
            lock_path.write_text(json.dumps({"pid": 1, "host": "other", "started": "x", "token": "thief"}))

    o = run_one(cfg, spec, progress=thief)
    assert o.outcome == "locked" and "taken over" in o.message
    assert json.loads(lock_path.read_text())["token"] == "thief"  # the new owner's lock is kept
    assert not (cfg.run_dir(spec.run_id) / schema.TRAJECTORY).exists()
    assert read_status(cfg.run_dir(spec.run_id))["status"] == "running"


def test_changed_run_settings_are_refused_not_mixed(done_sweep, tmp_path):
    """Same output dir, other frame spacing: done runs are not silently reused nor
    overwritten (more steps extend them instead: tests/test_extend_until.py)."""
    path, cfg = done_sweep
    other = tmp_path / "other.yaml"
    other.write_text(path.read_text().replace("sample_every: 20,", "sample_every: 50,"))
    traj = cfg.run_dir(cfg.runs()[0].run_id) / schema.TRAJECTORY
    before = traj.stat().st_mtime_ns
    r = CliRunner().invoke(cli, ["simulate", str(other), "--task-index", "0"])
    assert r.exit_code == 1
    assert "computed with other run settings (sample_every 20 -> 50)" in r.output
    assert traj.stat().st_mtime_ns == before
    assert read_status(traj.parent)["status"] == "done"


def test_spilling_frames_between_checkpoints_gives_same_file(done_sweep, tmp_path, monkeypatch):
    """Frames written early (buffer over SPILL_BYTES) change nothing in the result."""
    from fcsweep.sweep import runner

    _, ref = done_sweep
    monkeypatch.setattr(runner, "SPILL_BYTES", 0)  # append after every frame
    cfg = ref.with_output(tmp_path / "spill")
    spec = cfg.runs()[1]
    assert runner.run_one(cfg, spec).outcome == "done"
    _same(cfg.run_dir(spec.run_id) / schema.TRAJECTORY, ref.run_dir(spec.run_id) / schema.TRAJECTORY)


@pytest.mark.parametrize("cores,workers,layout", [(2, 1, (1, 2)), (2, 2, (2, 1)), (2, 8, (2, 1)), (16, 3, (3, 5)),
                                                  (1, 4, (1, 1))])
def test_worker_layout_never_oversubscribes(cores, workers, layout, monkeypatch):
    from fcsweep.io.machine import worker_layout

    monkeypatch.setattr("fcsweep.io.machine.available_cores", lambda: cores)
    processes, threads = worker_layout(workers)
    assert (processes, threads) == layout and processes * threads <= cores


@pytest.mark.parametrize("text,cpus", [("200000 100000\n", 2), ("150000 100000", 2), ("max 100000", None),
                                       ("garbage", None)])
def test_cgroup_cpu_quota_caps_the_cores(text, cpus, tmp_path):
    from fcsweep.io.machine import cgroup_cpu_quota

    f = tmp_path / "cpu.max"
    f.write_text(text)
    assert cgroup_cpu_quota(str(f)) == cpus
    assert cgroup_cpu_quota(str(tmp_path / "missing")) is None
