"""The floors of the house: model and io at the bottom, then analysis (arrays only: it opens
no file), results (the files of analysis), the sweep runner and the CLI on top; nothing
below the CLI imports the CLI."""

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


#: Imports no module under fcsweep/analysis/ may make: file formats, and the layers above it.
ANALYSIS_FORBIDDEN = ("h5py", "netCDF4", "fcsweep.io", "fcsweep.results", "fcsweep.sweep", "fcsweep.cli")
#: xarray's file functions (methods or module functions): analysis takes datasets, never files.
XARRAY_FILE_IO = {"open_dataset", "open_dataarray", "open_mfdataset", "open_zarr", "load_dataset",
                  "load_dataarray", "to_netcdf", "to_zarr"}


def _called_names(path: Path) -> set[str]:
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Call):
            f = node.func
            out.add(f.attr if isinstance(f, ast.Attribute) else getattr(f, "id", ""))
    return out


@pytest.mark.parametrize("path", sorted((PKG / "analysis").rglob("*.py")), ids=lambda p: str(p.relative_to(PKG)))
def test_analysis_takes_arrays_and_opens_no_file(path):
    bad = {m for m in _imports(path) if m == "fcsweep" or any(m == f or m.startswith(f + ".")
                                                              for f in ANALYSIS_FORBIDDEN)}
    assert not bad, f"{path.name} imports {bad}"
    calls = _called_names(path) & XARRAY_FILE_IO
    assert not calls, f"{path.name} calls {calls}"


@pytest.mark.parametrize("path", sorted((PKG / "results").rglob("*.py")), ids=lambda p: str(p.relative_to(PKG)))
def test_results_sit_below_the_sweep_runner_and_the_cli(path):
    bad = {m for m in _imports(path) if m.startswith(("fcsweep.sweep", "fcsweep.cli"))}
    assert not bad, f"{path.name} imports {bad}"


@pytest.mark.parametrize("path", sorted(p for p in PKG.rglob("*.py") if "cli" not in p.relative_to(PKG).parts[:1]),
                         ids=lambda p: str(p.relative_to(PKG)))
def test_nothing_below_the_cli_imports_it(path):
    assert not {m for m in _imports(path) if m == "fcsweep.cli" or m.startswith("fcsweep.cli.")}


@pytest.mark.parametrize("path", sorted((PKG / "io").glob("*.py")), ids=lambda p: p.name)
def test_io_imports_nothing_above_it(path):
    """io and model are the bottom floor: io may read model (the observable table), nothing else."""
    bad = {m for m in _imports(path) if m.startswith("fcsweep.") and not m.startswith(("fcsweep.io", "fcsweep.model"))}
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



def _module_of(path: Path) -> str:
    parts = path.relative_to(PKG.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


@pytest.mark.parametrize("path", sorted(PKG.rglob("*.py")), ids=lambda p: str(p.relative_to(PKG)))
def test_no_private_name_is_imported_from_another_module(path):
    """A name another module needs is public: nothing imports an ``_underscore`` name (dunder
    names aside) from another fcsweep module."""
    here = _module_of(path)
    package = here if path.name == "__init__.py" else here.rsplit(".", 1)[0]
    bad = []
    for node in ast.walk(ast.parse(path.read_text())):
        if not isinstance(node, ast.ImportFrom):
            continue
        base = package.split(".")[: len(package.split(".")) - node.level + 1] if node.level else []
        source = ".".join([*base, node.module] if node.module else base) if node.level else (node.module or "")
        if not source.startswith("fcsweep"):
            continue
        bad += [f"{a.name} from {source}" for a in node.names
                if a.name.startswith("_") and not a.name.startswith("__") and source != here]
    assert not bad, f"{path.relative_to(PKG)} imports private names: {bad}"
