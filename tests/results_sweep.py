"""A small analysed sweep (4 synthetic runs, analysis.h5 each, phase_diagram.nc) for the
tests of the results commands' writes (not part of the package)."""

from __future__ import annotations

import hashlib
import shutil
from pathlib import Path

import pytest
from test_aggregate_pipeline import YAML, fake_done_runs

from fcsweep.config import parse_config


def build(out: Path) -> Path:
    """Write the sweep into ``out``, analyse and aggregate it; return its config file."""
    from fcsweep.results.aggregate import aggregate_sweep
    from fcsweep.results.analyze import analyze_sweep

    cfg_file = out / "sweep.yaml"
    cfg_file.write_text(YAML.format(out=out / "sweep"))
    cfg = parse_config(cfg_file.read_text())
    fake_done_runs(cfg, out / "sweep", fluid_below=0.05, T=61)
    analyze_sweep(cfg)
    aggregate_sweep(cfg)
    return cfg_file


def copy(src_cfg: Path, dst: Path) -> Path:
    """A copy of the sweep of ``src_cfg`` in ``dst``; returns the copy's config file."""
    shutil.copytree(src_cfg.parent / "sweep", dst / "sweep")
    cfg_file = dst / "sweep.yaml"
    cfg_file.write_text(YAML.format(out=dst / "sweep"))
    return cfg_file


def results(sweep: Path) -> dict[str, str]:
    """sha256 of every analysis.h5 and the dataset, by relative path."""
    files = sorted(sweep.glob("runs/*/analysis.h5")) + [sweep / "phase_diagram.nc"]
    return {str(p.relative_to(sweep)): hashlib.sha256(p.read_bytes()).hexdigest() for p in files if p.exists()}


def temporaries(root: Path) -> list[Path]:
    """Temporary or partial files anywhere under ``root``."""
    return [p for p in root.rglob(".*") if ".tmp" in p.name or "partial" in p.name]


@pytest.fixture(scope="module")
def analysed(tmp_path_factory):
    """The analysed sweep, built once per test module."""
    return build(tmp_path_factory.mktemp("analysed"))


@pytest.fixture
def sweep(analysed, tmp_path):
    """A fresh copy of it per test: (config, sweep directory, its result files)."""
    cfg = copy(analysed, tmp_path)
    return cfg, tmp_path / "sweep", results(tmp_path / "sweep")
