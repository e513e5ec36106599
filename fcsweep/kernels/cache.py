"""Where the compiled kernels are cached: a directory named after a hash of their sources.

Numba invalidates a cache entry only when the file of that very function changes, not
when a function it inlines from another module does, nor when a module-level constant it
reads from another module changes (the contact-arc constants live in
:mod:`fcsweep.model.rates`); a stale entry can then crash or silently compute with old
constants.  The kernels are therefore cached in a directory named after a hash of the
kernel sources and the model modules they import (:func:`cache_dir`)::

    $NUMBA_CACHE_DIR/fcsweep-<hash>   if NUMBA_CACHE_DIR is set (read-only installs,
                                       clusters: point it at a writable scratch path)
    ~/.cache/fcsweep/numba-<hash>     otherwise ($XDG_CACHE_HOME is honoured)

Each kernel's dispatcher is given its own cache (:func:`kernel_cache`, attached by
:func:`fcsweep.kernels.options.njit`) that looks there; numba's process-wide settings
(``numba.config.CACHE_DIR``) are left alone, so other numba code in the same process
caches where it always does.
"""

from __future__ import annotations

import ast
import functools
import hashlib
import os
from pathlib import Path

from numba.core.caching import CompileResultCacheImpl, FunctionCache, UserProvidedCacheLocator

__all__ = ["cache_dir", "kernel_cache"]

_KERNELS = Path(__file__).parent
_MODEL = _KERNELS.parent / "model"


def model_sources(kernel_files) -> list[Path]:
    """The model modules the kernels import, and the model modules those import in turn
    (the declared tables in model/ that no kernel reads do not invalidate the cache)."""
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
            elif node.level == 1 and path.parent == _MODEL:  # from .x (a model module)
                name = mod.split(".")[0]
            else:
                continue
            f = _MODEL / f"{name}.py"
            if f.exists() and f not in seen:
                seen.add(f)
                todo.append(f)
    return sorted(seen)


@functools.lru_cache(maxsize=None)
def _cache_dir(base: str | None, xdg: str | None) -> Path:
    kernels = sorted(_KERNELS.glob("*.py"))
    h = hashlib.sha256()
    for f in kernels + model_sources(kernels):
        h.update(f"{f.parent.name}/{f.name}".encode())
        h.update(f.read_bytes())
    tag = h.hexdigest()[:12]
    if base:
        return Path(base) / f"fcsweep-{tag}"
    return Path(xdg or Path.home() / ".cache") / "fcsweep" / f"numba-{tag}"


def cache_dir() -> Path:
    """The directory the kernels of these sources are cached in (``$NUMBA_CACHE_DIR`` and
    ``$XDG_CACHE_HOME`` as they are now; nothing is created)."""
    return _cache_dir(os.environ.get("NUMBA_CACHE_DIR") or None, os.environ.get("XDG_CACHE_HOME") or None)


class _KernelLocator(UserProvidedCacheLocator):
    """Numba's locator for a user-given directory, given :func:`cache_dir` instead of
    ``numba.config.CACHE_DIR`` (same layout: ``<dir>/kernels_<sha1 of the source dir>``)."""

    def __init__(self, py_func, py_file):
        self._py_file = py_file
        self._lineno = py_func.__code__.co_firstlineno
        self._cache_path = str(cache_dir() / self.get_suitable_cache_subpath(py_file))

    @classmethod
    def from_function(cls, py_func, py_file):
        # the source-file mixin's constructor (creates the directory; None if not writable),
        # without UserProvidedCacheLocator's test of numba.config.CACHE_DIR
        return super(UserProvidedCacheLocator, cls).from_function(py_func, py_file)


class _KernelCacheImpl(CompileResultCacheImpl):
    _locator_classes = [_KernelLocator]


class _KernelCache(FunctionCache):
    _impl_class = _KernelCacheImpl


def kernel_cache(py_func):
    """A numba function cache for ``py_func`` in :func:`cache_dir`, or None when that
    directory cannot be created or written (the kernel is then compiled in every process)."""
    try:
        return _KernelCache(py_func)
    except RuntimeError:  # numba: "no locator available"
        return None
