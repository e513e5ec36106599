"""One state vocabulary: the displayed states are the schema's, one rule says whether an
analysis is current, and the sweep options travel as one frozen record."""

from __future__ import annotations

import dataclasses
import json
import os

import h5py
import pytest

from fcsweep.io import schema
from fcsweep.io.rundir import analysis_is_current
from fcsweep.io.status import write_status
from fcsweep.io.sweepdir import run_state
from fcsweep.sweep.options import SweepOptions
from fcsweep.sweep.status import STATES, analysis_state, summary_line


def _analysis(run_dir, settings: dict, rules: int | None = schema.LABEL_RULES) -> None:
    run_dir.mkdir(parents=True, exist_ok=True)
    with h5py.File(run_dir / schema.ANALYSIS, "w") as f:
        f.attrs[schema.ANALYSIS_SETTINGS_ATTR] = json.dumps(settings, sort_keys=True)
        if rules is not None:
            f.attrs[schema.LABEL_RULES_ATTR] = rules


def test_displayed_states_are_the_schema_states():
    assert sorted(STATES) == sorted(schema.STATUSES)
    line = summary_line([{"state": s} for s in schema.STATUSES])
    assert all(f"1 {s}" in line for s in schema.STATUSES), line


def test_recorded_word_and_state_differ_where_the_files_say_more(tmp_path):
    """status.json says running, no lock holds it: the state is interrupted; the recorded
    word stays what the runner wrote (the life cycle decides on it)."""
    write_status(tmp_path, {"status": schema.RUNNING})
    rs = run_state(tmp_path)
    assert (rs.state, rs.recorded) == (schema.INTERRUPTED, schema.RUNNING)
    assert run_state(tmp_path / "none").recorded is None


def test_analysis_is_current_one_rule(tmp_path):
    run = tmp_path / "run"
    path, traj = run / schema.ANALYSIS, run / schema.TRAJECTORY
    assert not analysis_is_current(path) and analysis_state(run, 0.2) == "no"
    settings = {"transient": 0.2, "label_confidence": 0.95}
    _analysis(run, settings)
    assert analysis_is_current(path, settings=settings)
    assert not analysis_is_current(path, settings={**settings, "transient": 0.3})
    assert analysis_is_current(path, transient=0.2) and not analysis_is_current(path, transient=0.3)
    assert analysis_state(run, 0.2, settings) == "yes" and analysis_state(run, 0.3) == "stale"
    traj.write_bytes(b"")
    t = path.stat().st_mtime
    os.utime(traj, (t + 10, t + 10))  # a trajectory newer than its analysis
    assert not analysis_is_current(path, traj, settings=settings)
    assert analysis_is_current(path, settings=settings)  # without the trajectory: settings only
    assert analysis_state(run, 0.2, settings) == "stale"
    path.write_bytes(b"not hdf5")
    os.utime(traj, (t - 10, t - 10))
    assert not analysis_is_current(path, traj, settings=settings) and analysis_state(run, 0.2) == "stale"


def test_an_analysis_of_former_label_rules_is_stale(tmp_path):
    """Same settings, but made before the last label-rule change (or before revisions were
    recorded): stale, so `fcsweep analyze` relabels it."""
    settings = {"transient": 0.2, "label_confidence": 0.95}
    for rules in (None, schema.LABEL_RULES - 1):
        run = tmp_path / f"run{rules}"
        _analysis(run, settings, rules)
        assert not analysis_is_current(run / schema.ANALYSIS, settings=settings)
        assert analysis_state(run, 0.2, settings) == "stale"


def test_sweep_options_are_one_frozen_record():
    o = SweepOptions(executor="process", workers=3)
    with pytest.raises(dataclasses.FrozenInstanceError):
        o.force = True  # type: ignore[misc]
    assert o.skip_failed
    assert not SweepOptions(retry_failed=True).skip_failed and not SweepOptions(force=True).skip_failed
    with pytest.raises(ValueError, match="executor"):
        SweepOptions(executor="threads")
