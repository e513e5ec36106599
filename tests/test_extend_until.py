"""Converged answers at least cost: extending finished runs bit for bit, ``run.until``
(stop when settled, deterministic across a kill), cost accounting and the status view."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest
from click.testing import CliRunner

from fcsweep.cli import cli
from fcsweep.config import ConfigError, load_config, parse_config
from fcsweep.io.h5md import read_parameters
from fcsweep.io.status import read_status, write_status
from fcsweep.sweep.bench import BenchRow, first_stop
from fcsweep.sweep.executors import run_sweep
from fcsweep.sweep.length import extension_of, same_physics
from fcsweep.sweep.runner import fingerprint_of, run_one
from fcsweep.sweep.status import collect_status, cost_totals
from test_pipeline_resume import assert_same_trajectory

SHORT = """
output: {out}
seed: 11
grid:
  v0: [0.02, 0.06]
model: {{N: 16, eta: 0.1}}
run: {{steps: {steps}, sample_every: 20, checkpoint_every: 100}}
"""

#: Rigid discs at area fraction 0.95 with fast polarity (Dr = 1): jammed, a clear-cut
#: solid whose labels settle at the first check (2000 steps = 10 persistence times).
UNTIL = """
output: {out}
seed: 3
grid:
  v0: [0.3]
model: {{N: 36, eta: 0.1, Dr: 1.0, modes: 0}}
run:
  steps: {cap}
  sample_every: 20
  checkpoint_every: 1000
  until: {until}
"""


def _cfg(tmp_path, name, text):
    p = tmp_path / f"{name}.yaml"
    p.write_text(text)
    return p, load_config(p)


@pytest.fixture(scope="module")
def extended(tmp_path_factory):
    root = tmp_path_factory.mktemp("extend")
    _, short = _cfg(root, "short", SHORT.format(out=root / "a", steps=400))
    long_path, long = _cfg(root, "long", SHORT.format(out=root / "a", steps=800))
    ref = long.with_output(root / "b")
    assert all(o.outcome == "done" for o in run_sweep(short, short.runs()))
    stale = long.run_dir(long.runs()[0].run_id) / "analysis.h5"
    stale.write_text("analysis of the 400-step trajectory")
    before = collect_status(long)
    outs = run_sweep(long, long.runs())
    assert all(o.outcome == "done" for o in run_sweep(ref, ref.runs()))
    return long_path, long, ref, before, outs, stale


def test_run_ids_do_not_depend_on_the_run_length(tmp_path):
    a = parse_config(SHORT.format(out=tmp_path, steps=400)).runs()
    b = parse_config(SHORT.format(out=tmp_path, steps=800)).runs()
    assert [s.run_id for s in a] == [s.run_id for s in b] and [s.seed for s in a] == [s.seed for s in b]


def test_raising_steps_extends_done_runs_bit_for_bit(extended):
    _, long, ref, before, outs, stale = extended
    assert [r["extend"] for r in before] == ["to 800 steps"] * 2
    assert all(r["state"] == "done" and r["steps_done"] == 400 for r in before)
    for o, spec in zip(outs, long.runs()):
        assert o.outcome == "done" and o.message.startswith("extended from step 400")
        traj = long.run_dir(spec.run_id) / "trajectory.h5"
        assert_same_trajectory(traj, ref.run_dir(spec.run_id) / "trajectory.h5")
        par = read_parameters(traj)
        assert (par["steps"], par["steps_done"], par["stop_reason"], par["complete"]) == (800, 800, "steps", 1)
        st = read_status(long.run_dir(spec.run_id))
        # the extension integrated only the 400 new steps: total work = N x 800
        assert st["cell_steps"] == st["cell_steps_computed"] == 16 * 800
        assert st["cpu_seconds"] > 0 and st["stop_reason"] == "steps"
    assert not stale.exists()  # the 400-step analysis went with the 400-step trajectory
    assert all(r["extend"] is None for r in collect_status(long))


def test_status_shows_extension_and_cost(extended):
    long_path, long, _, _, _, _ = extended
    res = CliRunner().invoke(cli, ["status", str(long_path).replace("long", "short")])
    assert res.exit_code == 0, res.output
    lines = res.output.splitlines()
    assert any("cpu[s]" in ln and ln.lstrip().startswith("idx") for ln in lines) and lines[-1].endswith("0 pending")
    # 2 runs x 16 cells x 800 steps
    assert any(ln.startswith("cost: 2.56e+04 cell-steps in trajectories") for ln in lines), res.output


def test_old_fingerprints_with_steps_are_reused(extended):
    _, long, _, _, _, _ = extended
    spec = long.runs()[1]
    rd = long.run_dir(spec.run_id)
    st = read_status(rd)
    old = json.loads(fingerprint_of(long, spec))
    st["fingerprint"] = json.dumps({**old, "steps": 800}, sort_keys=True)  # as written before the split
    write_status(rd, st)
    assert same_physics(st["fingerprint"], fingerprint_of(long, spec))
    assert not same_physics(json.dumps({**old, "seed": 1}), fingerprint_of(long, spec))
    assert run_one(long, spec).outcome == "skipped"


def test_extension_rule():
    run = parse_config(UNTIL.format(out="x", cap=4000, until="{check_every: 1000}")).run
    assert extension_of(run, {"steps_done": 4000, "stop_reason": "steps"}) is None
    assert extension_of(run, {"steps_done": 2000, "stop_reason": "steps"}) == "to 4000 steps"
    assert extension_of(run, {"steps_done": 2000, "stop_reason": "settled", "until": run.until.as_dict()}) is None
    changed = {**run.until.as_dict(), "confidence": 0.9}
    assert "other run.until" in extension_of(run, {"steps_done": 2000, "stop_reason": "settled", "until": changed})
    # the check analysed with another transient: its verdict does not hold for this config
    assert extension_of(run, {"steps_done": 2000, "stop_reason": "settled", "until": run.until.as_dict(),
                              "transient": 0.5}) is not None


def test_until_stops_a_clear_case_early_and_at_the_same_step_after_a_kill(tmp_path):
    until = "{check_every: 1000, min_steps: 2000, confidence: 0.95}"
    path, cfg = _cfg(tmp_path, "u", UNTIL.format(out=tmp_path / "killed", cap=20000, until=until))
    ref = cfg.with_output(tmp_path / "ref")
    (o,) = run_sweep(ref, ref.runs())
    spec = ref.runs()[0]
    st = read_status(ref.run_dir(spec.run_id))
    assert o.outcome == "done" and st["stop_reason"] == "settled"
    assert st["steps_done"] == 2000  # the first check: the whole window (8/Dr after the transient) reads solid
    assert st["check"]["settled"] and st["check"]["phase_confidence"] >= 0.95 and st["check"]["phase"] == 0
    assert st["check_cpu_seconds"] > 0 and st["cell_steps"] == 36 * 2000
    par = read_parameters(ref.run_dir(spec.run_id) / "trajectory.h5")
    assert (par["stop_reason"], par["steps_done"], par["steps"]) == ("settled", 2000, 20000)
    assert json.loads(par["until_json"])["confidence"] == 0.95

    # killed right after the checkpoint at the first check step, before the check ran;
    # and after the settled trajectory was renamed into place, before status.json said so
    for kill in ("checkpoint:2", "finalize:1"):
        killed = cfg.with_output(tmp_path / kill.replace(":", "_"))
        p = tmp_path / f"{kill.replace(':', '_')}.yaml"
        p.write_text(path.read_text().replace(str(tmp_path / "killed"), str(killed.output)))
        env = {**os.environ, "FCSWEEP_TEST_KILL_AT": kill}
        res = subprocess.run([sys.executable, "-m", "fcsweep.cli", "simulate", str(p), "-q"], env=env,
                             capture_output=True, text=True)
        assert res.returncode == -9, res.stdout + res.stderr
        assert read_status(killed.run_dir(spec.run_id))["status"] == "running"
        (o,) = run_sweep(killed, killed.runs())
        st2 = read_status(killed.run_dir(spec.run_id))
        assert o.outcome == "done" and (st2["stop_reason"], st2["steps_done"]) == ("settled", 2000), kill
        assert_same_trajectory(killed.run_dir(spec.run_id) / "trajectory.h5",
                               ref.run_dir(spec.run_id) / "trajectory.h5")

    # raising the cap does not extend a run that settled under the same targets
    _, raised = _cfg(tmp_path, "u2", UNTIL.format(out=tmp_path / "ref", cap=40000, until=until))
    assert collect_status(raised)[0]["extend"] is None
    assert run_one(raised, raised.runs()[0]).outcome == "skipped"


def test_until_targets_not_met_run_to_the_cap(tmp_path):
    until = "{check_every: 1000, min_steps: 1000, rel_error: {psi6: 0.000001}}"
    _, cfg = _cfg(tmp_path, "cap", UNTIL.format(out=tmp_path / "cap", cap=2000, until=until))
    (o,) = run_sweep(cfg, cfg.runs())
    st = read_status(cfg.run_dir(cfg.runs()[0].run_id))
    assert o.outcome == "done" and (st["stop_reason"], st["steps_done"]) == ("steps", 2000)
    assert not st["check"]["settled"] and st["check"]["step"] == 2000
    assert any(u.startswith("psi6 relative error") for u in st["check"]["unmet"])
    totals = cost_totals(collect_status(cfg))
    assert totals["cell_steps"] == 36 * 2000 and totals["cpu_seconds"] >= totals["check_cpu_seconds"] > 0


@pytest.mark.parametrize("until,key", [
    ("{check_every: 1500}", "run.until.check_every = 1500 is not allowed; it must be a multiple of "
                            "run.checkpoint_every = 1000"),
    ("{check_every: 1000, min_steps: 30000}", "run.until.min_steps = 30000 is out of range; "
                                              "allowed 0 <= min_steps <= run.steps = 20000"),
    ("{check_every: 1000, confidence: 0.3}", "run.until.confidence = 0.3 is out of range; allowed 0.5 <= "),
    ("{check_every: 1000, rel_error: {D_eff: 2}}", "run.until.rel_error.D_eff = 2.0 is out of range; allowed 0 <"),
    ("{check_every: 1000, rel_error: {Deff: 0.1}}", "unknown key in run.until.rel_error: 'Deff'; did you mean 'D_eff'"),
    ("{check_evry: 1000}", "unknown key in run.until: 'check_evry'; did you mean 'check_every'"),
    ("{min_steps: 1000}", "run.until.check_every is missing"),
    ("5", "run.until = 5 must be a mapping"),
])
def test_until_validation_names_key_and_range(tmp_path, until, key):
    text = UNTIL.format(out=tmp_path / "never", cap=20000, until=until)
    with pytest.raises(ConfigError, match="^<string>: " + __import__("re").escape(key)):
        parse_config(text)
    p = tmp_path / "bad.yaml"
    p.write_text(text)
    res = CliRunner().invoke(cli, ["simulate", str(p)])
    assert res.exit_code == 2 and key in res.output and not (tmp_path / "never").exists()


def test_bench_range_with_until():
    run = parse_config(UNTIL.format(out="x", cap=20000, until="{check_every: 3000, min_steps: 4000}")).run
    assert first_stop(run) == 6000  # first check step at or past min_steps
    row = BenchRow({"N": 36}, 2, 2 * 36 * 20000.0, 1e6, True, cell_steps_min=2 * 36 * 6000.0)
    assert row.cpu_seconds_min == pytest.approx(0.3 * row.cpu_seconds)


def test_in_run_check_sees_the_labels_of_the_full_analysis(extended):
    """The check leaves out the curves and |Psi6| for speed; every number a label or a
    ``rel_error`` target can depend on must be the one ``fcsweep analyze`` computes."""
    from fcsweep.analysis.run_observables import KTHNY_SCALARS
    from fcsweep.io.trajectory import open_trajectory
    from fcsweep.results.analyze import settings_with, trajectory_observables
    from fcsweep.results.settle import assess_trajectory

    _, long, _, _, _, _ = extended
    path = long.run_dir(long.runs()[1].run_id) / "trajectory.h5"
    s = settings_with(transient=0.2)
    full, curves, _ = trajectory_observables(open_trajectory(path), s)
    lean, none, _ = trajectory_observables(open_trajectory(path), s, curves=False, psi6=False)
    assert set(curves) >= {"msd", "G6", "Gr"} and not set(none) & {"msd", "G6", "Gr"}
    assert np.isnan(lean["psi6"]) and np.isfinite(full["psi6"])
    for k, v in full.items():  # KTHNY comes from the curves, and no run.until target uses it
        if k not in ("psi6", "psi6_err", "kthny_reason") + KTHNY_SCALARS:
            assert lean[k] == v or (isinstance(v, float) and np.isnan(v) and np.isnan(lean[k])), k
    v = assess_trajectory(path, transient=0.2, confidence=0.5, rel_error={"psi6": 10.0}, threads=1)
    assert v.values["phase"] == full["phase"] and v.values["psi6_rel_error"] == pytest.approx(
        abs(full["psi6_err"] / full["psi6"]))
