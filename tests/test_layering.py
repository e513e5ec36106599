"""The floors of the house: analysis never imports the sweep runner (nor the CLI), and
nothing below the CLI imports the CLI."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PKG = Path(__file__).resolve().parent.parent / "fcsweep"


def _imports(path: Path) -> set[str]:
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module:
            out.add(node.module)
        elif isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
    return out


@pytest.mark.parametrize("path", sorted((PKG / "analysis").rglob("*.py")), ids=lambda p: str(p.relative_to(PKG)))
def test_analysis_does_not_import_sweep_or_cli(path):
    bad = {m for m in _imports(path) if m.startswith(("fcsweep.sweep", "fcsweep.cli"))}
    assert not bad, f"{path.name} imports {bad}"


@pytest.mark.parametrize("path", sorted(p for p in PKG.rglob("*.py") if "cli" not in p.relative_to(PKG).parts[:1]),
                         ids=lambda p: str(p.relative_to(PKG)))
def test_nothing_below_the_cli_imports_it(path):
    assert not {m for m in _imports(path) if m == "fcsweep.cli" or m.startswith("fcsweep.cli.")}


@pytest.mark.parametrize("path", sorted((PKG / "io").glob("*.py")), ids=lambda p: p.name)
def test_io_imports_nothing_above_it(path):
    bad = {m for m in _imports(path) if m.startswith("fcsweep.") and not m.startswith("fcsweep.io")}
    assert not bad, f"{path.name} imports {bad}"


@pytest.mark.parametrize("path", sorted((PKG / "model").glob("*.py")), ids=lambda p: p.name)
def test_model_imports_only_model(path):
    bad = {m for m in _imports(path) if m.startswith("fcsweep.") and not m.startswith("fcsweep.model")}
    assert not bad, f"{path.name} imports {bad}"


@pytest.mark.parametrize("path", sorted((PKG / "config").glob("*.py")), ids=lambda p: p.name)
def test_config_sits_on_model_and_io(path):
    allowed = ("fcsweep.config", "fcsweep.model", "fcsweep.io")
    bad = {m for m in _imports(path) if m.startswith("fcsweep.") and not m.startswith(allowed)}
    assert not bad, f"{path.name} imports {bad}"


@pytest.mark.parametrize("path", sorted((PKG / "measure").glob("*.py")), ids=lambda p: p.name)
def test_measure_sits_with_analysis(path):
    """fcsweep.measure reads images with the analysis estimators: analysis, model, io and itself only."""
    allowed = ("fcsweep.measure", "fcsweep.analysis", "fcsweep.model", "fcsweep.io")
    bad = {m for m in _imports(path) if m.startswith("fcsweep.") and not m.startswith(allowed)}
    assert not bad, f"{path.name} imports {bad}"
