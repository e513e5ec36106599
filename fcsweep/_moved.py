"""Old import paths of moved modules keep working: ``import fcsweep.analysis.pipeline`` gives
the module object of :mod:`fcsweep.results.analyze`, the same object, so its functions,
classes and module globals (and ``monkeypatch.setattr`` on them) are shared.

:data:`MOVED` maps an old module name to its new one; a name below an old package (e.g.
``fcsweep.analysis.figures.common``) maps to the same name below the new package.  The
finder is installed by ``fcsweep/__init__.py``; the repository's own code uses the new paths.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.util
import sys

#: Old module name -> new module name.
MOVED = {
    "fcsweep.analysis.pipeline": "fcsweep.results.analyze",
    "fcsweep.analysis.aggregate": "fcsweep.results.aggregate",
    "fcsweep.analysis.export": "fcsweep.results.export",
    "fcsweep.analysis.results": "fcsweep.results.locate",
    "fcsweep.analysis.settle": "fcsweep.results.settle",
    "fcsweep.analysis.trajectory": "fcsweep.io.trajectory",
    "fcsweep.analysis.figures": "fcsweep.results.figures",
}


def new_name(old: str) -> str | None:
    """The module name that replaced ``old`` (None if it did not move)."""
    if old in MOVED:
        return MOVED[old]
    for prefix, target in MOVED.items():
        if old.startswith(prefix + "."):
            return target + old[len(prefix):]
    return None


class _AliasLoader(importlib.abc.Loader):
    """Loads an old name as the already imported new module (nothing is executed twice)."""

    def __init__(self, target: str):
        self.target = target
        self._spec = None

    def create_module(self, spec):
        module = importlib.import_module(self.target)
        self._spec = module.__spec__
        return module

    def exec_module(self, module):
        # the import system set the alias's spec on the module: give it its own back
        module.__spec__ = self._spec


class MovedFinder(importlib.abc.MetaPathFinder):
    """Finds the old names of :data:`MOVED`."""

    def find_spec(self, fullname, path=None, target=None):
        new = new_name(fullname)
        if new is None:
            return None
        return importlib.util.spec_from_loader(fullname, _AliasLoader(new), is_package=False)


def install() -> None:
    """Put one :class:`MovedFinder` first on :data:`sys.meta_path` (idempotent)."""
    if not any(isinstance(f, MovedFinder) for f in sys.meta_path):
        sys.meta_path.insert(0, MovedFinder())
