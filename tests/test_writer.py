"""The write path of a run (fcsweep.sweep.writer.RunWriter) and the file moves of its
directory (fcsweep.io.rundir.RunDirectory): which files exist after each step, and that
the writer driven by hand writes the very trajectory that run_one writes."""

from __future__ import annotations

import time

import h5py
import numpy as np
import pytest

from fcsweep.config import load_config
from fcsweep.io import schema
from fcsweep.io.checkpoint import load_checkpoint, split_meta
from fcsweep.io.h5md import read_parameters, seq_path, verify_trajectory
from fcsweep.io.rundir import RunDirectory
from fcsweep.io.status import read_status
from fcsweep.sweep.lifecycle import fingerprint_of
from fcsweep.sweep.runner import run_one
from fcsweep.sweep.writer import RunWriter, new_trajectory

N, SE, STEPS = 16, 20, 60
CONFIG = f"""
output: OUT
seed: 5
grid: {{v0: [0.05]}}
model: {{N: {N}, eta: 0.1}}
run: {{steps: {STEPS}, sample_every: {SE}, checkpoint_every: 40}}
"""


def _config(tmp_path, name):
    path = tmp_path / f"{name}.yaml"
    path.write_text(CONFIG.replace("OUT", str(tmp_path / name)))
    return load_config(path)


def _names(path) -> list[str]:
    return sorted(p.name for p in path.iterdir())


def _datasets(path) -> dict[str, np.ndarray]:
    out = {}
    with h5py.File(path, "r") as f:
        f.visititems(lambda n, o: out.__setitem__(n, o[()]) if isinstance(o, h5py.Dataset) else None)
    return out


def _write_by_hand(cfg):
    """Start, commit and checkpoint at step 40, then finish at step 60, as run_one does."""
    from fcsweep.simulation import Simulation

    spec = cfg.runs()[0]
    rd = RunDirectory(cfg.run_dir(spec.run_id), spec.run_id, spec.index, spec.params)
    rd.path.mkdir(parents=True)
    (rd.path / f".{schema.CHECKPOINT}.999.tmp").write_bytes(b"left by a killed writer")
    assert rd.acquire()
    seen = {}
    try:
        rd.remove_temporaries()
        seen["start"] = _names(rd.path)
        sim = Simulation.from_lattice(N, **spec.model_params())
        fp = fingerprint_of(cfg, spec)
        fields = new_trajectory(cfg, spec, rd, sim, fp)
        w = RunWriter(cfg, spec, rd, sim, fields=fields, written=0, fingerprint=fp, reason="",
                      cost={k: 0.0 for k in schema.COST_KEYS}, t0=time.time(), c0=time.process_time())
        rd.begin({"steps": STEPS, "fingerprint": fp, "attempts": 1})
        w.sample()
        for _ in range(2):
            sim.advance(SE)
            w.sample()
        assert (w.written, len(w.buffer)) == (0, 3)
        w.commit()
        w.checkpoint(40)
        seen["checkpoint"] = _names(rd.path)
        seen["committed"] = rd.committed_frames()
        sim.advance(SE)
        w.sample()
        w.stop_at(60)
        done = w.finalize("steps")
    finally:
        rd.release()
    return rd, done, seen


def test_writer_steps_leave_the_expected_files_and_match_run_one(tmp_path):
    cfg = _config(tmp_path, "hand")
    rd, done, seen = _write_by_hand(cfg)
    assert seen["start"] == [schema.LOCK]  # the temporary is gone
    live = [schema.TRAJECTORY_PARTIAL, seq_path(schema.TRAJECTORY_PARTIAL).name]  # and its write counter
    assert seen["checkpoint"] == sorted([schema.CHECKPOINT, schema.LOCK, schema.STATUS, *live])
    assert seen["committed"] == 3
    # promoted: no partial file, no write counter, no temporary, lock released
    assert _names(rd.path) == sorted([schema.CHECKPOINT, schema.STATUS, schema.TRAJECTORY])
    assert done == STEPS and verify_trajectory(rd.trajectory, STEPS // SE + 1) is None
    par = read_parameters(rd.trajectory)
    assert (par["complete"], par["stop_reason"], par["steps_done"]) == (1, "steps", STEPS)
    st = read_status(rd.path)
    assert st["status"] == schema.DONE and st["steps_done"] == STEPS
    assert st["cell_steps"] == st["cell_steps_computed"] == N * STEPS
    meta = split_meta(load_checkpoint(rd.checkpoint))[1]
    assert (meta["frames"], meta["step"]) == (STEPS // SE + 1, STEPS)

    ref = _config(tmp_path, "ref")
    spec = ref.runs()[0]
    assert run_one(ref, spec).outcome == "done"
    a, b = _datasets(rd.trajectory), _datasets(ref.run_dir(spec.run_id) / schema.TRAJECTORY)
    assert sorted(a) == sorted(b)
    for name in a:  # bit for bit: the writer is run_one's write path
        assert a[name].tobytes() == b[name].tobytes(), name


def test_reopen_and_start_over_move_only_the_run_files(tmp_path):
    cfg = _config(tmp_path, "hand")
    rd, _, _ = _write_by_hand(cfg)
    before = _datasets(rd.trajectory)
    for name in (schema.ANALYSIS, schema.ANALYSIS_ERROR):
        (rd.path / name).write_bytes(b"of the shorter run")
    rd.reopen()
    assert _names(rd.path) == sorted([schema.CHECKPOINT, schema.STATUS, schema.TRAJECTORY_PARTIAL])
    assert read_parameters(rd.partial)["complete"] == 0
    after = _datasets(rd.partial)
    assert all(before[k].tobytes() == after[k].tobytes() for k in before)
    rd.start_over()
    assert _names(rd.path) == [schema.STATUS]


@pytest.mark.parametrize("analysis", [True, False])
def test_remove_trajectory_keeps_or_drops_the_analysis(tmp_path, analysis):
    rd = RunDirectory(tmp_path / "r", "r", 0)
    rd.path.mkdir()
    for name in (schema.TRAJECTORY, schema.ANALYSIS, schema.ANALYSIS_ERROR):
        (rd.path / name).write_bytes(b"x")
    rd.remove_trajectory(analysis=analysis)
    assert _names(rd.path) == ([] if analysis else sorted([schema.ANALYSIS, schema.ANALYSIS_ERROR]))
    rd.remove_trajectory()  # nothing left to remove: no error
