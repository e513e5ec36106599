"""One owner of a run's life cycle: every command names the same state, and the dry run
predicts what ``simulate`` then does.

Run directories in every state are made from two tiny real runs (16 cells, 400 steps)
by copying and damaging files; for each, ``status``, the dry run (:func:`plan_runs`),
``analyze`` and ``aggregate`` are asked what state the run is in, and ``simulate`` is run
to check the dry run's action, its start step, and (when it computes) that the
trajectory is bit for bit the uninterrupted one.
"""

from __future__ import annotations

import json
import os
import shutil
import socket
import subprocess
import time

import h5py
import numpy as np
import pytest
from click.testing import CliRunner

from fcsweep.results import analyze as pipeline
from fcsweep.results.aggregate import STATUS_FLAGS, build_dataset
from fcsweep.results.analyze import analyze_run, analyze_sweep
from fcsweep.cli import cli
from fcsweep.config import load_config
from fcsweep.io import schema
from fcsweep.io.checkpoint import load_checkpoint, save_checkpoint, split_meta
from fcsweep.io.refinement import append_round
from fcsweep.io.status import read_status, write_status
from fcsweep.sweep.executors import run_sweep
from fcsweep.sweep.options import SweepOptions
from fcsweep.sweep.plan import plan_runs
from fcsweep.sweep.runner import run_one
from fcsweep.sweep.status import collect_status
from test_pipeline_resume import assert_same_trajectory

CONFIG = """
output: {out}
seed: {seed}
grid:
  v0: [0.05]
model: {{N: 16, eta: 0.1}}
run: {{steps: {steps}, sample_every: 20, checkpoint_every: 100{until}}}
"""
UNTIL = ", until: {check_every: 100, min_steps: 200}"


def _config(root, name, *, steps=400, seed=7, until=""):
    p = root / f"{name}.yaml"
    p.write_text(CONFIG.format(out=root / name, steps=steps, seed=seed, until=until))
    return p, load_config(p)


class _StopAfter:
    """A stop request after ``n`` looks (the runner checks between pieces of integration)."""

    def __init__(self, n):
        self.n = n

    def __call__(self):
        self.n -= 1
        return "SIGTERM" if self.n < 0 else None


@pytest.fixture(scope="module")
def base(tmp_path_factory):
    root = tmp_path_factory.mktemp("lifecycle")
    _, ref = _config(root, "reference")
    spec = ref.runs()[0]
    assert run_sweep(ref, [spec])[0].outcome == "done"
    _, short = _config(root, "short", steps=200)
    assert run_sweep(short, [spec])[0].outcome == "done"
    _, cut = _config(root, "cut")
    o = run_one(cut, spec, stop=_StopAfter(3))
    assert o.outcome == "interrupted" and 0 < o.steps_done < 400, o
    return root, ref, spec, {"done": ref.run_dir(spec.run_id), "short": short.run_dir(spec.run_id),
                             "interrupted": cut.run_dir(spec.run_id)}


def _edit_status(rd, **fields):
    st = read_status(rd)
    st.update(fields)
    write_status(rd, st)


def _lock(rd, pid):
    (rd / schema.LOCK).write_text(json.dumps({"pid": pid, "host": socket.gethostname(), "token": "x",
                                              "started": time.strftime("%Y-%m-%dT%H:%M:%S")}))


def _dead_pid():
    p = subprocess.Popen(["true"])
    p.wait()
    return p.pid


def _flip(rd):
    traj = rd / schema.TRAJECTORY
    with h5py.File(traj, "r") as f:
        off = f["particles/cells/position/value"].id.get_chunk_info(0).byte_offset
    data = bytearray(traj.read_bytes())
    data[off + 16:off + 24] = bytes(b ^ 0xFF for b in data[off + 16:off + 24])
    traj.write_bytes(bytes(data))
    os.utime(traj, ns=(time.time_ns(), time.time_ns() + 10**9))


def _old_checkpoint(rd):
    state, meta = split_meta(load_checkpoint(rd / schema.CHECKPOINT))
    fp = json.loads(meta["fingerprint"])
    meta["fingerprint"] = json.dumps({**fp, "steps": 400}, sort_keys=True)  # written before the split
    save_checkpoint(rd / schema.CHECKPOINT, state, meta)


#: name -> (source run, damage, config variant, state, dry-run action)
TABLE = {
    "fresh": (None, None, {}, "pending", "start"),
    "running, live lock": ("interrupted", lambda rd: (_edit_status(rd, status="running"), _lock(rd, os.getpid())),
                           {}, "running", "locked"),
    "running, stale lock": ("interrupted", lambda rd: (_edit_status(rd, status="running"), _lock(rd, _dead_pid())),
                            {}, "interrupted", "resume"),
    "interrupted": ("interrupted", None, {}, "interrupted", "resume"),
    "failed, simulation": ("interrupted", lambda rd: _edit_status(rd, status="failed", cause="simulation",
                                                                  reason="RuntimeError: x"), {}, "failed", "failed"),
    "failed, conflict": ("interrupted", lambda rd: _edit_status(rd, status="failed", cause="conflict", reason="y"),
                         {}, "failed", "failed"),
    "failed, io": ("interrupted", lambda rd: _edit_status(rd, status="failed", cause="io",
                                                          reason="I/O error: no space left on device"),
                   {}, "failed", "resume"),
    "done": ("done", None, {}, "done", "skip"),
    "done, trajectory gone": ("done", lambda rd: (rd / schema.TRAJECTORY).unlink(), {}, "corrupt", "start"),
    "done, trajectory damaged": ("done", _flip, {}, "done", "start"),
    "corrupt": ("done", lambda rd: (_flip(rd), _edit_status(rd, status="corrupt")), {}, "corrupt", "start"),
    "old-version checkpoint": ("interrupted", _old_checkpoint, {}, "interrupted", "resume"),
    "other run settings": ("done", None, {"seed": 8}, "done", "blocked"),
    "settled": ("short", "settled", {"until": UNTIL}, "done", "skip"),
    "extendable": ("short", None, {}, "done", "extend"),
}


def _make(base, name, tag=""):
    root, _, spec, sources = base
    src, damage, variant, _, _ = TABLE[name]
    slug = name.replace(", ", "-").replace(" ", "-") + tag
    path, cfg = _config(root, slug, **variant)
    rd = cfg.run_dir(spec.run_id)
    if src is not None:
        shutil.copytree(sources[src], rd)
        if damage == "settled":  # stopped at step 200 by run.until under the config's settings
            _edit_status(rd, stop_reason="settled", transient=cfg.run.transient, until=cfg.run.until.as_dict())
        elif damage is not None:
            damage(rd)
    return path, cfg, rd


@pytest.mark.parametrize("name", list(TABLE))
def test_every_command_names_the_same_state_and_the_dry_run_predicts_simulate(base, name, monkeypatch):
    _, ref, _, _ = base
    path, cfg, rd = _make(base, name)
    spec = cfg.runs()[0]  # the same run id in every variant; its seed follows the config
    state, action = TABLE[name][3:]
    (row,) = collect_status(cfg)
    (plan,) = plan_runs(cfg, [spec])
    assert (row["state"], plan.state, plan.action) == (state, state, action), plan
    monkeypatch.setattr(pipeline, "_analyze_task", lambda *a: ("done", "analysed"))
    (res,) = analyze_sweep(cfg)
    if state == "done":
        assert res[1:] == ("done", "analysed")
    else:
        assert res[1] == "skipped" and res[2].startswith("not run" if not rd.exists() else f"run {state}"), res
    code = int(build_dataset(cfg)["status"].values.ravel()[0])
    assert STATUS_FLAGS[code] == ("not_analysed" if state == "done" else state)  # the state `fcsweep status` shows
    monkeypatch.undo()

    (o,) = run_sweep(cfg, [spec])
    expect = {"start": "done", "resume": "done", "extend": "done", "skip": "skipped", "locked": "locked",
              "failed": "failed", "blocked": "failed"}[action]
    assert o.outcome == expect, o
    if action == "resume":
        assert f"resumed from step {plan.from_step}" in o.message and plan.steps_left == 400 - plan.from_step
    elif action == "extend":
        assert f"extended from step {plan.from_step}" in o.message and plan.from_step == 200
    elif action == "start":
        assert plan.from_step == 0 and plan.steps_left == 400 and "resumed" not in o.message
    elif action == "blocked":
        assert "computed with other run settings" in o.message and "--force recomputes it" in plan.note
    if expect == "done":
        assert_same_trajectory(rd / schema.TRAJECTORY, ref.run_dir(spec.run_id) / schema.TRAJECTORY)
        assert collect_status(cfg)[0]["state"] == "done"
    if name == "failed, simulation":  # the dry run with --retry-failed predicts the rerun too
        (plan,) = plan_runs(cfg, [spec], SweepOptions(retry_failed=True))
        (o,) = run_sweep(cfg, [spec], SweepOptions(retry_failed=True))
        assert plan.action == "resume" and f"resumed from step {plan.from_step}" in o.message


def test_dry_run_counts_an_io_failure_as_work(base):
    """Finding: a run failed with cause io was listed as "failed earlier ...; --retry-failed
    reruns it" with no cost, though simulate resumes it without --retry-failed."""
    path, cfg, _ = _make(base, "failed, io", "-cli")
    res = CliRunner().invoke(cli, ["simulate", str(path), "--dry-run"])
    assert res.exit_code == 0, res.output
    assert "failed earlier" not in res.output and "1 to resume" in res.output and "estimated" in res.output


def test_status_and_analyze_name_a_missing_trajectory_corrupt(base):
    path, cfg, rd = _make(base, "done, trajectory gone", "-cli")
    res = CliRunner().invoke(cli, ["status", str(path)])
    assert "corrupt" in res.output and "trajectory.h5 is missing" in res.output, res.output
    (run_id, what, msg), = analyze_sweep(cfg)
    assert what == "skipped" and msg == "run corrupt: trajectory.h5 damaged: trajectory.h5 is missing"
    (plan,) = plan_runs(cfg, cfg.runs())
    assert plan.note == "trajectory.h5 damaged: trajectory.h5 is missing; recomputed"


def test_old_version_checkpoint_resumes_in_the_dry_run_too(base):
    path, _, _ = _make(base, "old-version checkpoint", "-cli")
    res = CliRunner().invoke(cli, ["simulate", str(path), "--dry-run"])
    assert "blocked" not in res.output and "1 to resume" in res.output, res.output


def test_analyze_sweep_reads_the_runs_once(base):
    """Points added by `refine --add-only` from another shell while analyze runs are left
    for the next call instead of raising KeyError."""
    root, ref, spec, _ = base
    _, cfg = _config(root, "refined-meanwhile")
    calls = []

    class OtherShell:
        run, output = cfg.run, cfg.output

        def runs(self):
            calls.append(1)
            append_round(cfg.output, [{"v0": 0.06 + 0.01 * len(calls)}], ["test"], "now")
            return cfg.with_refinement().runs()

    res = analyze_sweep(OtherShell())
    assert len(calls) == 1 and [r[0] for r in res] == [s.run_id for s in cfg.with_refinement().runs()]
    assert len(res) == 2


def test_runs_read_no_file_and_list_runs_takes_the_output(base, tmp_path):
    root, _, _, _ = base
    path, cfg = _config(root, "bound")
    append_round(cfg.output, [{"v0": 0.07}], ["test"], "now")
    assert len(cfg.runs()) == 1 and len(load_config(path).runs()) == 2
    other = cfg.with_output(tmp_path / "elsewhere")
    assert len(other.runs()) == 1  # -o elsewhere: that directory's points (none)
    count = CliRunner().invoke(cli, ["list-runs", str(path), "-o", str(tmp_path / "elsewhere"), "--count"])
    assert count.output.strip() == "1"
    assert CliRunner().invoke(cli, ["list-runs", str(path), "--count"]).output.strip() == "2"


def test_structure_frame_count_is_that_of_the_voronoi_statistics(base, tmp_path):
    """n_structure_frames counts the frames after the transient (those the Voronoi
    statistics sample), not those after the equilibration cut."""
    root, ref, spec, _ = base
    _, cfg = _config(root, "frames")
    rd = cfg.run_dir(spec.run_id)
    shutil.copytree(ref.run_dir(spec.run_id), rd)
    analyze_run(rd / schema.TRAJECTORY, transient=cfg.run.transient)
    with h5py.File(rd / schema.ANALYSIS, "r+") as f:  # as if the cut had trimmed 8 of the 17 frames
        g = f["observables"]
        t0, t1 = g.attrs["t_start"], g.attrs["t_end"]
        g.attrs["n_frames"], g.attrs["t_equilibrated"] = 9.0, t0 + 8 * (t1 - t0) / 16
    with h5py.File(rd / schema.TRAJECTORY, "r") as f:
        total = f["particles/cells/position/step"].shape[0]
    after = total - int(np.ceil(cfg.run.transient * (total - 1) - 1e-9))
    assert after == 17
    ds = build_dataset(cfg)
    assert float(ds["n_structure_frames"].values.ravel()[0]) == min(after, 100)
