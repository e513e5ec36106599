"""The `fcsweep` command line: the built-in demo end to end, list-runs, validate, usage errors."""

from __future__ import annotations

import json
import os
from pathlib import Path

import h5py
import pytest
from click.testing import CliRunner

from fcsweep.cli import cli
from fcsweep.config import builtin_demo_path, load_config
from fcsweep.sweep import bench

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def demo_dir(tmp_path_factory):
    """`fcsweep simulate` with no argument, run in an empty directory."""
    d = tmp_path_factory.mktemp("demo")
    cwd = os.getcwd()
    os.chdir(d)
    try:
        r = CliRunner().invoke(cli, ["simulate"])
    finally:
        os.chdir(cwd)
    assert r.exit_code == 0, r.output
    assert "built-in demo" in r.output and "4 computed" in r.output
    return d


def test_demo_runs_into_fcsweep_demo(demo_dir, monkeypatch):
    monkeypatch.chdir(demo_dir)
    cfg = load_config(builtin_demo_path())
    assert sorted(os.listdir(demo_dir)) == ["fcsweep-demo"]
    for s in cfg.runs():
        with h5py.File(demo_dir / "fcsweep-demo" / "runs" / s.run_id / "trajectory.h5", "r") as f:
            assert f["particles/cells/position/value"].shape == (251, 64, 2)
    r = CliRunner().invoke(cli, ["status"])
    assert r.exit_code == 0 and "4 runs: 4 done" in r.output


def test_demo_analyze_aggregate_plot(demo_dir, monkeypatch, tmp_path):
    """The README's chain after the demo: analyze, aggregate, plot take the same default."""
    pytest.importorskip("fcsweep.results.analyze")
    monkeypatch.chdir(demo_dir)
    r = CliRunner().invoke(cli, ["analyze", "--workers", "1"])
    assert r.exit_code == 0, r.output
    r = CliRunner().invoke(cli, ["aggregate"])
    assert r.exit_code == 0, r.output
    assert (demo_dir / "fcsweep-demo" / "phase_diagram.nc").exists()
    # the demo answers: a solid, a fluid and a soft fluid, decided, one line per point
    for word in ("solid (P = ", "eta=0.3 v0=0.2 N=64: fluid (P = ", "soft-fluid (P = "):
        assert word in r.output, r.output
    r = CliRunner().invoke(cli, ["plot", "--outdir", str(tmp_path / "figs")])
    assert r.exit_code == 0, r.output
    assert any((tmp_path / "figs").iterdir())


def test_list_runs_and_count():
    path = ROOT / "configs" / "phase.yaml"
    r = CliRunner().invoke(cli, ["list-runs", str(path), "--count"])
    assert r.exit_code == 0 and r.output.strip() == "36"
    r = CliRunner().invoke(cli, ["list-runs", str(path)])
    lines = r.output.strip().splitlines()
    assert len(lines) == 36
    idx, rid, *params = lines[7].split()
    cfg = load_config(path)
    assert int(idx) == 7 and rid == cfg.runs()[7].run_id and params == ["eta=0.02", "v0=0.02", "N=1024"]
    js = json.loads(CliRunner().invoke(cli, ["list-runs", str(path), "--json"]).output)
    assert js[7]["params"]["seed"] == cfg.runs()[7].seed


def test_validate_and_usage_errors(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    r = CliRunner().invoke(cli, ["validate", str(ROOT / "configs" / "phase.yaml")])
    assert r.exit_code == 0 and "OK, 36 runs" in r.output
    r = CliRunner().invoke(cli, ["simulate", str(ROOT / "configs" / "smoke.yaml"), "--task-index", "4"])
    assert r.exit_code == 2 and "runs 0..3" in r.output
    r = CliRunner().invoke(cli, ["simulate", "missing.yaml"])
    assert r.exit_code == 2 and "cannot read config file" in r.output
    assert os.listdir(tmp_path) == []
    r = CliRunner().invoke(cli, ["--version"])
    assert r.exit_code == 0 and "version" in r.output


def test_run_checks_refuse_to_run_but_keep_results_readable(tmp_path, monkeypatch):
    """A config whose dt exceeds the tension limit (e.g. a sweep computed before the check
    existed): validate / simulate / bench exit 2, status and list-runs still read it."""
    monkeypatch.chdir(tmp_path)
    bad = ROOT / "tests" / "data" / "bad_configs" / "37_dt_above_tension_limit.yaml"
    for cmd in ("validate", "simulate", "bench"):
        r = CliRunner().invoke(cli, [cmd, str(bad)])
        assert r.exit_code == 2 and "allowed: 0 < dt <= 0.0136" in r.output, (cmd, r.output)
    r = CliRunner().invoke(cli, ["list-runs", "--count", str(bad)])
    assert r.exit_code == 0, r.output
    r = CliRunner().invoke(cli, ["status", str(bad)])  # read, found nothing simulated: 1, not 2
    assert r.exit_code == 1 and "nothing simulated in" in r.output, r.output
    assert os.listdir(tmp_path) == []


def test_bench_times_each_setting_and_adds_up_the_sweep(tmp_path, monkeypatch):
    """Two N (two cost settings), --compare arc: one row per (setting, rule); the work of a
    setting is N x steps x its runs; the sweep's CPU time counts only its own rule."""
    path = tmp_path / "b.yaml"
    path.write_text("output: out\ngrid:\n  N: [16, 36]\n  v0: [0.01, 0.03]\nmodel:\n  eta: 0.05\n"
                    "  quadrature: binary\nrun:\n  steps: 300\n  sample_every: 100\n")
    monkeypatch.chdir(tmp_path)
    r = CliRunner().invoke(cli, ["bench", str(path), "--compare", "binary", "--compare", "arc", "--steps", "20",
                                 "--warm", "20", "--json", "-j", "2"])
    assert r.exit_code == 0, r.output
    out = json.loads(r.output[r.output.index("{"):])
    rows = {(row["N"], row["quadrature"]): row for row in out["rows"]}
    assert set(rows) == {(16, "binary"), (16, "arc"), (36, "binary"), (36, "arc")}
    for (N, _), row in rows.items():
        assert row["runs"] == 2 and row["cell_steps"] == N * 300 * 2
        assert 1e3 < row["cell_steps_per_s"] < 1e9
        assert row["cpu_seconds"] == pytest.approx(row["cell_steps"] / row["cell_steps_per_s"])
    own = rows[(16, "binary")]["cpu_seconds"] + rows[(36, "binary")]["cpu_seconds"]
    # plus what each of the 4 runs spends outside the step (one checkpoint each: 300 steps)
    overhead = 4 * (bench.RUN_CPU_S + bench.CHECKPOINT_CPU_S)
    assert out["sweep_cpu_seconds"] == pytest.approx(own + overhead)
    assert out["sweep_wall_seconds"] >= (own + overhead) / 2 - 1e-12
    assert not (tmp_path / "out").exists()  # timing writes no run output


def test_bench_times_each_integrator_and_compares_only_rules_it_can_use(tmp_path, monkeypatch):
    """The integrator sets the step's cost: a sweep over integrators gets one row each;
    contact-jacobi (arc only) is not timed with the binary rule of --compare."""
    path = tmp_path / "b.yaml"
    path.write_text("output: out\ngrid:\n  integrator: [euler, contact-jacobi]\nmodel:\n  N: 16\n  eta: 0.05\n"
                    "  v0: 0.03\n  quadrature: arc\nrun:\n  steps: 300\n  sample_every: 100\n")
    monkeypatch.chdir(tmp_path)
    r = CliRunner().invoke(cli, ["bench", str(path), "--compare", "binary", "--compare", "arc", "--steps", "20",
                                 "--warm", "20", "--json"])
    assert r.exit_code == 0, r.output
    out = json.loads(r.output[r.output.index("{"):])
    got = {(row["integrator"], row["quadrature"]) for row in out["rows"]}
    assert got == {("euler", "binary"), ("euler", "arc"), ("contact-jacobi", "arc")}


def test_help_lists_every_command_in_the_declared_order():
    from fcsweep.cli import COMMAND_ORDER

    assert sorted(COMMAND_ORDER) == sorted(cli.commands)  # a new command must be placed in the order
    r = CliRunner().invoke(cli, ["--help"])
    listed = [line.split()[0] for line in r.output.split("Commands:")[1].splitlines() if line.strip()]
    assert listed == list(COMMAND_ORDER)


def test_executor_dask_without_distributed_stops_before_any_run(tmp_path, monkeypatch):
    """Without the `cluster` extra, `--executor dask` says what to install in one line and
    exits 2 before anything is written."""
    import builtins

    real_import = builtins.__import__

    def no_distributed(name, *args, **kwargs):
        if name == "distributed" or name.startswith("distributed."):
            raise ImportError("No module named 'distributed'")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_distributed)
    monkeypatch.chdir(tmp_path)
    r = CliRunner().invoke(cli, ["simulate", str(ROOT / "configs" / "smoke.yaml"), "-o", "out", "--executor", "dask",
                                 "--scheduler", "tcp://127.0.0.1:1"])
    assert r.exit_code == 2, r.output
    lines = r.stderr.splitlines()
    assert len(lines) == 1 and 'pip install "fcsweep[cluster]"' in lines[0], r.stderr
    assert os.listdir(tmp_path) == []
