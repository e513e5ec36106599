"""The notebook API: ``fcsweep.Simulation(...).run`` records frames in memory and
``fcsweep.observables`` returns what ``fcsweep analyze`` stores for the same run."""

from __future__ import annotations

import json

import h5py
import numpy as np
import pytest
from click.testing import CliRunner

import fcsweep
from fcsweep.cli import cli
from fcsweep.io.trajectory import open_trajectory
from fcsweep.model.observables import CURVES, LABELS, REASON_CODES, REASONS, RUN_SCALARS
from fcsweep.model.parameters import PARAMETERS

# a fluid point of the demo (eta 0.3, v0 0.2, 64 cells, Dr 0.1), 60 time units, a frame every 2
CONFIG = """
output: {out}
seed: 11
grid:
  v0: [0.2]
model: {{N: 64, eta: 0.3, Dr: 0.1, dt: 0.005, quadrature: binary}}
run: {{steps: 12000, sample_every: 400, checkpoint_every: 4000, transient: 0.2}}
"""


@pytest.fixture(scope="module")
def analysed_run(tmp_path_factory):
    """One run through ``fcsweep simulate`` and ``fcsweep analyze``: its trajectory and analysis."""
    d = tmp_path_factory.mktemp("api")
    cfg = d / "sweep.yaml"
    cfg.write_text(CONFIG.format(out=d / "out"))
    for cmd in ("simulate", "analyze"):
        r = CliRunner().invoke(cli, [cmd, str(cfg), "-q"] if cmd == "simulate" else [cmd, str(cfg)])
        assert r.exit_code == 0, r.output
    (run_dir,) = (d / "out" / "runs").iterdir()
    return run_dir / "trajectory.h5", run_dir / "analysis.h5"


def _frames_of(traj_path):
    """The same run made again in memory: its stored parameters and seed, the same frames."""
    p = open_trajectory(traj_path).params
    model = {k: p[k] for k in PARAMETERS if k != "N" and k in p}
    sim = fcsweep.Simulation.create(int(p["N"]), seed=int(p["seed"]), **model)
    dt = float(p["dt"])
    return sim.run(int(p["steps"]) * dt, every=int(p["sample_every"]) * dt)


def test_observables_in_memory_equal_what_analyze_stores(analysed_run):
    traj_path, analysis_path = analysed_run
    frames = _frames_of(traj_path)
    assert len(frames) == 31 and frames.n_cells == 64
    with h5py.File(traj_path, "r") as f:  # the frames themselves, bit for bit
        stored = f["particles/cells/position/value"][...]
    np.testing.assert_array_equal(frames.position, stored)
    ds = fcsweep.observables(frames, transient=0.2)
    with h5py.File(analysis_path, "r") as f:
        obs = dict(f["observables"].attrs)
        curves = {name: f["curves"][name][...] for name in CURVES}
    # equal up to the order of float64 sums (the file is read in blocks of cells, memory whole):
    # 1e-12 relative is 10^4 roundings of 1.1e-16
    for name in RUN_SCALARS:
        np.testing.assert_allclose(float(ds[name]), float(obs[name]), rtol=1e-12, atol=0, err_msg=name)
    for label in LABELS:
        assert int(ds[f"{label}_code"]) == int(obs[label])
    for name in REASONS:
        assert ds[name].item() == str(obs[name])
    for name in REASON_CODES:
        assert int(ds[name]) == int(obs[name])
    for name, values in curves.items():
        np.testing.assert_allclose(ds[name].values, values, rtol=1e-12, atol=1e-300, err_msg=name)


def test_the_dataset_names_labels_in_words_with_errors(analysed_run):
    ds = fcsweep.observables(analysed_run[0])  # from the file: the same path as analyze
    for name in ("D_eff", "q_mean", "rho_d", "largest_cluster_fraction"):
        assert np.isfinite(float(ds[name])) and float(ds[f"{name}_err"]) > 0, name
    assert ds["phase"].item() in ("solid", "fluid", "soft_fluid", "undetermined", "unknown")
    codes = dict(zip(ds["phase_code"].attrs["flag_values"].tolist(), ds["phase_code"].attrs["flag_meanings"].split()))
    assert codes[int(ds["phase_code"])] == ds["phase"].item()
    settings = json.loads(ds.attrs["settings_json"])
    assert settings["transient"] == 0.2 and settings["label_confidence"] == 0.95


def test_an_undetermined_label_has_no_confidence():
    """Too short a run for D_eff (5 time units < 8/Dr): undetermined, and its confidence NaN,
    never a probability near 1 beside it."""
    sim = fcsweep.Simulation.create(64, eta=0.3, v0=0.02, Dr=0.1, seed=3)
    ds = fcsweep.observables(sim.run(5.0, every=0.5))
    assert ds["phase"].item() == "undetermined", ds["phase_reason"].item()
    assert np.isnan(float(ds["phase_confidence"]))
    reason = ds["phase_reason"].item()
    assert reason.startswith("run too short for D_eff"), reason
    # the window is what is left after the transient and the equilibration cut: the reason says which
    cut = float(ds["t_equilibrated"]) - float(ds["t_start"])
    assert (f"equilibration cut at t = {float(ds['t_equilibrated']):.4g}" in reason) == (cut > 0), reason
    assert ("after the transient" in reason) == (cut == 0), reason


def test_bad_arguments_are_refused_before_anything_runs():
    sim = fcsweep.Simulation.create(16, eta=0.3, v0=0.02, Dr=0.1, seed=3)
    with pytest.raises(ValueError, match="every = 0.0033 must be >= 0 and a whole number of steps"):
        sim.run(1.0, every=0.0033)
    with pytest.raises(ValueError, match="divides time"):
        sim.run(1.0, every=0.3)
    assert sim.state.step == 0
    frames = sim.run(0.5, every=0.25)
    with pytest.raises(ValueError, match="unknown analysis setting"):
        fcsweep.observables(frames, transeint=0.2)
    with pytest.raises(ValueError, match="label_confidence = 1.5 is out of range"):
        fcsweep.observables(frames, label_confidence=1.5)


def test_run_continues_the_run():
    """Two calls of run are one run: the second's frames are those of one long call."""
    a = fcsweep.Simulation.create(16, eta=0.3, v0=0.2, Dr=0.1, seed=5)
    b = fcsweep.Simulation.create(16, eta=0.3, v0=0.2, Dr=0.1, seed=5)
    first, second = a.run(1.0, every=0.5), a.run(1.0, every=0.5)
    whole = b.run(2.0, every=0.5)
    np.testing.assert_array_equal(first.position[-1], second.position[0])
    np.testing.assert_array_equal(second.position, whole.position[2:])
    np.testing.assert_array_equal(second.time, whole.time[2:])
