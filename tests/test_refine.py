"""Refinement: midpoints between neighbours with differing or undetermined labels,
recorded in the sweep directory and seen by runs(), list-runs, analyze and aggregate."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import xarray as xr
from click.testing import CliRunner

from fcsweep.results.aggregate import STATUS_FLAGS, aggregate_sweep
from fcsweep.analysis.phase import PERCOLATION_FLAGS, PHASE_FLAGS
from fcsweep.results.analyze import analyze_sweep
from fcsweep.cli import cli
from fcsweep.config import ConfigError, parse_config
from fcsweep.io.refinement import append_round, read_points
from fcsweep.sweep.refine import point_labels, propose_points
from test_aggregate_pipeline import YAML, write_trajectory

SOLID, FLUID, SOFT, UND = 0, 1, 2, 3


def lab(phase, perc=0):
    return {"phase": phase, "percolated": perc}


def test_midpoints_between_differing_labels_only():
    # eta (log axis) x v0: solid at large eta, fluid at small eta; the boundary lies
    # between eta 0.01 and 0.1 at v0 = 0.03 and between 0.001 and 0.01 at v0 = 0.06
    labels = {(0.001, 0.03): lab(FLUID), (0.01, 0.03): lab(FLUID), (0.1, 0.03): lab(SOLID),
              (0.001, 0.06): lab(FLUID), (0.01, 0.06): lab(SOLID), (0.1, 0.06): lab(SOLID)}
    props = propose_points(labels, ["eta", "v0"], log_axes=["eta"],
                           flag_names={"phase": PHASE_FLAGS, "percolated": PERCOLATION_FLAGS})
    pts = [tuple(p.point.values()) for p in props]
    # along eta: geometric midpoints (12 significant digits); along v0: at eta = 0.01 the labels differ too
    assert set(pts) == {(float(f"{math.sqrt(0.001):.12g}"), 0.03), (float(f"{math.sqrt(1e-5):.12g}"), 0.06),
                        (0.01, 0.045)}
    assert props[0].why == "v0 between 0.03 (fluid/not_percolated) and 0.06 (solid/not_percolated) at eta=0.01"


def test_priority_unknown_undetermined_and_max_points():
    labels = {(0.0,): lab(SOLID), (1.0,): lab(SOLID), (2.0,): lab(UND), (3.0,): lab(FLUID),
              (5.0,): lab(FLUID, 1), (9.0,): lab(-1)}
    props = propose_points(labels, ["v0"])
    # determined labels that differ first (3|5: percolation), then pairs with an undetermined
    # end (1|2, 2|3: equal gaps, in coordinate order)
    assert [p.point["v0"] for p in props] == [4.0, 1.5, 2.5]
    assert [p.point["v0"] for p in propose_points(labels, ["v0"], max_points=1)] == [4.0]
    # no point between equal determined labels (0|1) nor next to an unknown one (5|9)
    assert propose_points({(1,): lab(SOLID), (2,): lab(FLUID)}, ["N"]) == []  # no integer between


@pytest.fixture
def synthetic(tmp_path):
    """2 x 2 synthetic sweep (fluid at eta = 0.01, solid at eta = 0.1), analysed."""
    cfg = parse_config(YAML.format(out=tmp_path))

    def make(specs):
        for spec in specs:
            rd = tmp_path / "runs" / spec.run_id
            if rd.exists():
                continue
            rd.mkdir(parents=True)
            write_trajectory(rd / "trajectory.h5", {**dict(spec.params), "run_id": spec.run_id},
                             fluid=spec.params["eta"] < 0.05, seed=spec.index)
            (rd / "status.json").write_text(json.dumps({"status": "done", "steps_done": 2000, "cell_steps": 72000}))
        bound = cfg.with_refinement()  # the points recorded so far, as the commands read them
        analyze_sweep(bound)
        return aggregate_sweep(bound)

    return cfg, make


def test_refined_points_are_runs_and_aggregate_holds_a_non_product_grid(synthetic, tmp_path):
    cfg, make = synthetic
    path = make(cfg.runs())
    with xr.open_dataset(path) as ds:
        labels = point_labels(ds, cfg.runs(), cfg.swept)
    assert {k: v["phase"] for k, v in labels.items()}[(0.1, 0.03)] == SOLID
    props = propose_points(labels, cfg.swept, max_points=1)
    assert len(props) == 1 and props[0].point["eta"] == 0.055  # linear axis: arithmetic midpoint
    append_round(cfg.output, [p.point for p in props], [p.why for p in props], "now")
    assert len(cfg.runs()) == 4  # a config reads the refinement file once, when it is bound
    runs = cfg.with_refinement().runs()
    assert len(runs) == 5 and runs[4].index == 4 and runs[4].params["eta"] == 0.055
    assert [r.run_id for r in runs[:4]] == [r.run_id for r in parse_config(YAML.format(out=tmp_path / "x")).runs()]
    listed = CliRunner().invoke(cli, ["list-runs", "--count", str(_yaml(tmp_path))])
    assert listed.output.strip() == "5"
    path = make(runs)
    with xr.open_dataset(path) as ds:
        assert ds.sizes["eta"] == 3 and ds.sizes["v0"] == 2
        new = ds.sel(eta=0.055, replicate=0, N=36)
        ran = new.sel(v0=props[0].point["v0"])
        other = new.sel(v0=[v for v in (0.03, 0.06) if v != props[0].point["v0"]][0])
        assert STATUS_FLAGS[int(ran["status"])] == "analysed" and np.isfinite(float(ran["D_eff"]))
        assert STATUS_FLAGS[int(other["status"])] == "missing" and np.isnan(float(other["D_eff"]))  # nothing ran there
        assert ds.attrs["total_cell_steps"] == 5 * 72000  # summed over the 5 runs' status files
    assert read_points(cfg.output) == [props[0].point]


def _yaml(tmp_path):
    p = tmp_path / "sweep.yaml"
    p.write_text(YAML.format(out=tmp_path))
    return p


def test_refinement_file_must_fit_the_grid(tmp_path):
    cfg = parse_config(YAML.format(out=tmp_path))
    append_round(tmp_path, [{"eta": 0.05}], ["test"], "now")
    with pytest.raises(ConfigError, match="refinement.json point 0 has parameters"):
        cfg.with_refinement().runs()


REAL = """
output: {out}
seed: 5
grid:
  v0: [0.02, 0.06]
model: {{N: 16, eta: 0.1}}
run: {{steps: 400, sample_every: 20, checkpoint_every: 200}}
"""


def test_refine_command_simulates_analyses_and_aggregates_new_points(tmp_path):
    """400 steps are far too short for D_eff at Dr = 0.01: every label is undetermined,
    so one round adds the midpoint of the only pair."""
    p = tmp_path / "real.yaml"
    p.write_text(REAL.format(out=tmp_path / "out"))
    res = CliRunner().invoke(cli, ["refine", str(p), "--rounds", "1", "--max-points", "1", "-q"])
    assert res.exit_code == 0, res.output
    assert "v0=0.04" in res.output
    assert read_points(tmp_path / "out") == [{"v0": 0.04}]
    status = CliRunner().invoke(cli, ["status", str(p), "--json"])
    rows = json.loads(status.output)
    assert [r["state"] for r in rows] == ["done"] * 3 and rows[2]["label"] == "v0=0.04"
    again = CliRunner().invoke(cli, ["simulate", str(p), "--task-index", "2"])  # job arrays see the point
    assert again.exit_code == 0 and "0 computed, 1 already done" in again.output
    with xr.open_dataset(tmp_path / "out" / "phase_diagram.nc") as ds:
        assert ds["v0"].values.tolist() == [0.02, 0.04, 0.06]
        assert (ds["status"].values == 0).all()
        assert ds.attrs["total_cell_steps"] == 3 * 16 * 400


def test_refine_add_only_records_points_and_prints_their_indices(synthetic, tmp_path):
    cfg, make = synthetic
    make(cfg.runs())
    res = CliRunner().invoke(cli, ["refine", str(_yaml(tmp_path)), "--add-only", "--max-points", "2"])
    assert res.exit_code == 0, res.output
    assert "new runs 4..5, e.g. sbatch --array=4-5" in res.output
    cfg = cfg.with_refinement()
    assert len(read_points(tmp_path)) == 2 and len(cfg.runs()) == 6
    assert not any((tmp_path / "runs" / r.run_id).exists() for r in cfg.runs()[4:])  # nothing computed
