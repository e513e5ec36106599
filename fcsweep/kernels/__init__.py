"""Numba kernels of the contour model (ndarrays and scalars in, no Python objects).

Compiled code is cached on disk (``cache=True``).  Numba invalidates a cache entry only
when the file of that very function changes, not when a function it inlines from another
module does, nor when a module-level constant it reads from another module changes (the
contact-arc constants live in :mod:`fcsweep.model.rates`); a stale entry can then crash
or silently compute with old constants.  The cache therefore lives in a directory named
after a hash of the kernel sources and the model modules they import::

    $NUMBA_CACHE_DIR/fcsweep-<hash>   if NUMBA_CACHE_DIR is set (read-only installs,
                                       clusters: point it at a writable scratch path)
    ~/.cache/fcsweep/numba-<hash>     otherwise ($XDG_CACHE_HOME is honoured)
"""

from __future__ import annotations

import ast
import hashlib
import os
from pathlib import Path

import numba.core.config as _nb_config


def _model_sources(kernel_files) -> list[Path]:
    """The model modules the kernels import, and the model modules those import in turn
    (the declared tables in model/ that no kernel reads do not invalidate the cache)."""
    model = Path(__file__).parent.parent / "model"
    todo, seen = list(kernel_files), set()
    while todo:
        path = todo.pop()
        for node in ast.walk(ast.parse(path.read_text())):
            if not isinstance(node, ast.ImportFrom) or not node.module:
                continue
            mod = node.module
            if mod.startswith("fcsweep.model."):
                name = mod.split(".")[2]
            elif node.level == 2 and mod.startswith("model."):  # from ..model.x (a kernel)
                name = mod.split(".")[1]
            elif node.level == 1 and path.parent == model:  # from .x (a model module)
                name = mod.split(".")[0]
            else:
                continue
            f = model / f"{name}.py"
            if f.exists() and f not in seen:
                seen.add(f)
                todo.append(f)
    return sorted(seen)


def _configure_cache() -> str:
    here = Path(__file__).parent
    kernels = sorted(here.glob("*.py"))
    h = hashlib.sha256()
    for f in kernels + _model_sources(kernels):
        h.update(f"{f.parent.name}/{f.name}".encode())
        h.update(f.read_bytes())
    tag = h.hexdigest()[:12]
    base = os.environ.get("NUMBA_CACHE_DIR")
    if base:
        path = os.path.join(base, f"fcsweep-{tag}")
    else:
        xdg = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
        path = os.path.join(xdg, "fcsweep", f"numba-{tag}")
    _nb_config.CACHE_DIR = path
    return path


CACHE_DIR = _configure_cache()
